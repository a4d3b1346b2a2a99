"""Alters a recorded IMU trial the way other sensors and drivers differ from the one that recorded it, so that an
estimator can be checked on what it was never tuned on: another rate, irregular intervals, held (repeated)
samples, a gyro that saturates, a magnetometer in other units with a hard-iron offset, a start in motion.

    python -m attitude_client.alter TRIAL.hdf5|TRIAL.csv --out OUT.csv [--rate HZ] [--jitter F] [--hold P]
        [--mag-every K] [--clip RAD_S] [--mag-scale S] [--mag-offset X,Y,Z] [--start-in-motion] [--seed N]
        [--drop-batches P [--batch N]] [--drop-burst T0,S]... [--fill]

Every alteration keeps the meaning of a sample: sample k's gyro rate covers ``(t_{k−1}, t_k]`` (the convention of
IMU drivers, VQF and the service), so a lower rate is the mean of the source's rates over each new interval (what a
sensor's own decimation filter gives, and exactly the same rotation to first order); the accelerometer and the
magnetometer are averaged over the same interval (anti-aliased); the truth and ``movement`` are the source's at the
interval's last sample. Written as a CSV trial (docs/recordings.md) that ``attitude-lab imu-study`` and
``attitude-replay`` read, with the source's truth description (``align`` etc.) kept.

* ``--rate HZ``: resample onto a grid at HZ. Below the source's rate, as above. Above it, a faster sensor of the
  same kind: the rates follow a smooth curve through the source's (the integral over each source interval kept
  exactly; `resample`'s ``smooth``) and white noise is added so that each channel's noise density stays the
  source's (its noise measured in its quietest second, `quietest_noise`, times √(HZ / source rate − 1)), so
  that no two readings repeat or lie on a line, as a real sensor's never do.
* ``--jitter F``: irregular intervals: each interval is the nominal one times a uniform factor in ``[1 − F, 1 + F]``
  (F < 1), then resampled as above.
* ``--hold P``: with probability P a sample repeats the previous sample's values at its own (new) time, as a driver
  that publishes before the sensor has a new reading (the rate it holds then covers the interval too).
* ``--mag-every K``: the magnetometer updates every K-th sample and is held in between (a slower magnetometer).
* ``--clip R``: every gyro axis clipped at ±R rad/s (a sensor's range).
* ``--mag-scale S``, ``--mag-offset X,Y,Z``: the magnetometer times S plus a body-fixed offset (other units, a
  magnet that moves with the body).
* ``--start-in-motion``: drop every sample before the first ``movement`` sample (no opening rest).
* ``--drop-batches P --batch N``: the samples in batches of N, each lost with probability P (what a lossy
  link does to a sender's puts); ``--drop-burst T0,S``: every sample in ``[T0, T0 + S)`` lost (seconds from
  the first sample). Lost samples are gone: the next one comes after a gap (its rate still covers only its
  own interval). With ``--fill`` they are not gone but made up: each lost sample's gyro, accelerometer and
  magnetometer on the line between the real samples on both sides, at its own time (what a converter that
  resamples onto a uniform grid does across a hole, as RepoIMU's conversion did), so that nothing shows a gap.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .replay import CSV_COLUMNS, TRUTH_FILE_KEYS, load_trial


def resample(trial: dict, times: np.ndarray, smooth: bool = False) -> dict:
    """The trial on new sample times ``times`` (increasing, within the source's span). Source sample k holds its
    values over ``(t_{k−1}, t_k]`` (its rate covers that interval); new sample j gets the mean of that piecewise
    constant signal over ``(τ_{j−1}, τ_j]`` for the gyro, accelerometer and magnetometer (so the gyro's integral,
    the rotation to first order, is kept exactly), the truth interpolated at ``τ_j`` (slerp between the source
    samples around it; unknown where either is) and ``movement`` of the source sample that holds ``τ_j``. The first
    new sample takes the source's values at its time.

    With ``smooth`` (a rate above the source's) the signal is not held constant over each source interval (the
    new samples inside one would repeat one reading, a driver polling faster than its sensor) but follows the
    cubic Hermite curve of its integral through the source's interval edges, with the mean of the two readings
    around an edge as the slope there: the integral over every source interval is still exactly the source's, and
    the rate changes continuously, as a faster sensor's would."""
    t = np.asarray(trial["t"], dtype=float)
    times = np.asarray(times, dtype=float)
    dt = np.diff(t)
    # Sample k (k ≥ 1) holds (t_{k−1}, t_k]; sample 0 a nominal interval before t_0.
    edges = np.concatenate([[t[0] - (dt[0] if len(dt) else 1.0)], t])

    def integral(x: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """∫ from edges[0] to tau of x (held over each interval, or on the Hermite curve with ``smooth``)."""
        widths = np.diff(edges)
        cum = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x * widths[:, None], axis=0)])
        k = np.clip(np.searchsorted(edges, tau, side="right") - 1, 0, len(x) - 1)
        if not smooth:
            return cum[k] + x[k] * (tau - edges[k])[:, None]
        # The slope of the integral at each edge: the mean of the readings on both sides (the end ones at the ends).
        slope = np.concatenate([x[:1], 0.5 * (x[:-1] + x[1:]), x[-1:]])
        h = widths[k][:, None]
        u = np.clip((tau - edges[k])[:, None] / h, 0.0, 1.0)
        u2, u3 = u * u, u * u * u
        return (
            (2 * u3 - 3 * u2 + 1) * cum[k]
            + (u3 - 2 * u2 + u) * h * slope[k]
            + (-2 * u3 + 3 * u2) * cum[k + 1]
            + (u3 - u2) * h * slope[k + 1]
        )

    out = {k: v for k, v in trial.items() if k not in ("gyr", "acc", "mag", "opt_quat", "movement", "t")}
    holder = np.clip(np.searchsorted(t, times - 1e-12, side="left"), 0, len(t) - 1)
    for key in ("gyr", "acc", "mag"):
        x = np.asarray(trial[key], dtype=float)
        ints = integral(x, times)
        vals = np.empty((len(times), 3))
        vals[0] = x[holder[0]]
        span = np.diff(times)
        vals[1:] = (ints[1:] - ints[:-1]) / span[:, None]
        out[key] = vals
    if trial["opt_quat"] is None:
        out["opt_quat"] = None
    else:
        q = np.asarray(trial["opt_quat"], dtype=float)
        j = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
        f = np.clip((times - t[j]) / (t[j + 1] - t[j]), 0.0, 1.0)
        q0, q1 = q[j], q[j + 1].copy()
        q1[np.einsum("ij,ij->i", q0, q1) < 0] *= -1.0
        # Slerp by the relative rotation's angle; NaN where either end is unknown.
        d = np.clip(np.einsum("ij,ij->i", q0, q1), -1.0, 1.0)
        ang = np.arccos(d)
        with np.errstate(invalid="ignore", divide="ignore"):
            s = np.sin(ang)
            a = np.where(s > 1e-12, np.sin((1 - f) * ang) / s, 1 - f)
            b = np.where(s > 1e-12, np.sin(f * ang) / s, f)
        qi = a[:, None] * q0 + b[:, None] * q1
        out["opt_quat"] = qi / np.linalg.norm(qi, axis=1)[:, None]
    out["movement"] = None if trial["movement"] is None else np.asarray(trial["movement"])[holder]
    out["t"] = times
    out["rate_hz"] = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else trial["rate_hz"]
    return out


def quietest_noise(trial: dict, window_s: float = 1.0) -> dict:
    """Each channel's noise per axis (1σ, its units), measured where the trial is quietest: the window of
    ``window_s`` whose gyro varies least (a rest, if the trial has one)."""
    n = max(2, int(round(window_s * trial["rate_hz"])))
    gyr = np.asarray(trial["gyr"], dtype=float)
    if len(gyr) < n:
        n = len(gyr)
    starts = range(0, len(gyr) - n + 1, max(1, n // 2))
    best = min(starts, key=lambda k: float(np.std(gyr[k : k + n], axis=0).sum()))
    return {key: np.std(np.asarray(trial[key], dtype=float)[best : best + n], axis=0) for key in ("gyr", "acc", "mag")}


def alter(
    trial: dict,
    rate: float | None = None,
    jitter: float = 0.0,
    hold: float = 0.0,
    mag_every: int = 1,
    clip: float | None = None,
    mag_scale: float = 1.0,
    mag_offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
    start_in_motion: bool = False,
    seed: int = 1,
    drop_batches: float = 0.0,
    batch: int = 40,
    drop_bursts: tuple = (),
    fill: bool = False,
) -> dict:
    """The trial altered as the module documentation says (the alterations in that order)."""
    rng = np.random.default_rng(seed)
    out = dict(trial)
    if start_in_motion:
        mv = out["movement"]
        if mv is None or not mv.any():
            raise ValueError("--start-in-motion needs movement samples")
        first = int(np.argmax(mv))
        for key in ("gyr", "acc", "mag", "opt_quat", "movement", "t"):
            if out[key] is not None:
                out[key] = out[key][first:]
    if rate is not None or jitter > 0:
        if not (0.0 <= jitter < 1.0):
            raise ValueError("jitter must be in [0, 1)")
        r = rate if rate is not None else out["rate_hz"]
        t0, t1 = out["t"][0], out["t"][-1]
        n = int((t1 - t0) * r * 1.2) + 2
        dt = np.full(n, 1.0 / r) * (1.0 + jitter * rng.uniform(-1.0, 1.0, n))
        times = t0 + np.concatenate([[0.0], np.cumsum(dt)])
        times = times[times <= t1 + 1e-9]
        source_rate = out["rate_hz"]
        faster = r > source_rate * (1.0 + 1e-9)
        noise = quietest_noise(out) if faster else None
        out = resample(out, times, smooth=faster)
        if faster:
            # A faster sensor with the source's noise density: its readings' white noise grows as √rate. The
            # smooth curve keeps the source's (now spread over several samples); the rest is added, per
            # sample and independent (its own generator: the other alterations' draws stay as they were).
            extra = np.sqrt(r / source_rate - 1.0)
            draw = np.random.default_rng([seed, 1])
            for key in ("gyr", "acc", "mag"):
                out[key] = out[key] + draw.normal(size=out[key].shape) * (noise[key] * extra)
    n = len(out["t"])
    for key in ("gyr", "acc", "mag"):
        out[key] = np.array(out[key], dtype=float, copy=True)
    if hold > 0:
        held = rng.uniform(size=n) < hold
        held[0] = False
        for k in np.flatnonzero(held):
            for key in ("gyr", "acc", "mag"):
                out[key][k] = out[key][k - 1]
    if mag_every > 1:
        for k in range(n):
            if k % mag_every:
                out["mag"][k] = out["mag"][k - 1]
    if clip is not None:
        out["gyr"] = np.clip(out["gyr"], -clip, clip)
    out["mag"] = out["mag"] * mag_scale + np.asarray(mag_offset, dtype=float)
    if drop_batches > 0 or drop_bursts:
        keep = np.ones(n, dtype=bool)
        if drop_batches > 0:
            lost = rng.uniform(size=(n + batch - 1) // batch) < drop_batches
            keep &= ~np.repeat(lost, batch)[:n]
        t_rel = out["t"] - out["t"][0]
        for t0, span in drop_bursts:
            keep &= ~((t_rel >= t0) & (t_rel < t0 + span))
        keep[0] = True
        keep[-1] |= fill
        out["lost"] = int(n - keep.sum())
        if fill:
            t = out["t"]
            for key in ("gyr", "acc", "mag"):
                v = out[key]
                out[key] = np.column_stack([np.interp(t, t[keep], v[keep, j]) for j in range(3)])
        else:
            for key in ("gyr", "acc", "mag", "opt_quat", "movement", "t"):
                if out.get(key) is not None:
                    out[key] = out[key][keep]
    return out


def write_csv(trial: dict, path: Path) -> None:
    """A CSV trial (docs/recordings.md): the truth description as ``#`` lines, the header, a line per sample."""
    n = len(trial["t"])
    quat = trial["opt_quat"] if trial["opt_quat"] is not None else np.full((n, 4), np.nan)
    mv = trial["movement"] if trial["movement"] is not None else np.zeros(n, dtype=bool)
    with open(path, "w") as fh:
        for k, v in (trial.get("truth") or {}).items():
            if k in TRUTH_FILE_KEYS:
                fh.write(f"# {k}: {v}\n")
        fh.write(",".join(CSV_COLUMNS) + "\n")
        for k in range(n):
            fields = [repr(float(trial["t"][k]))]
            fields += [repr(float(x)) for x in trial["gyr"][k]]
            fields += [repr(float(x)) for x in trial["acc"][k]]
            fields += [repr(float(x)) for x in trial["mag"][k]]
            fields += ["" if not np.isfinite(x) else repr(float(x)) for x in quat[k]]
            fields.append("1" if mv[k] else "0")
            fh.write(",".join(fields) + "\n")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trial", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--rate", type=float)
    ap.add_argument("--jitter", type=float, default=0.0)
    ap.add_argument("--hold", type=float, default=0.0)
    ap.add_argument("--mag-every", type=int, default=1)
    ap.add_argument("--clip", type=float)
    ap.add_argument("--mag-scale", type=float, default=1.0)
    ap.add_argument("--mag-offset", default="0,0,0")
    ap.add_argument("--start-in-motion", action="store_true")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--drop-batches", type=float, default=0.0)
    ap.add_argument("--batch", type=int, default=40)
    ap.add_argument("--drop-burst", action="append", default=[], help="T0,SECONDS (repeatable)")
    ap.add_argument("--fill", action="store_true", help="lost samples made up on the line between the real ones")
    args = ap.parse_args()
    trial = load_trial(args.trial, None)
    offset = tuple(float(x) for x in args.mag_offset.split(","))
    if len(offset) != 3:
        ap.error("--mag-offset takes X,Y,Z")
    bursts = tuple(tuple(float(x) for x in b.split(",")) for b in args.drop_burst)
    out = alter(trial, args.rate, args.jitter, args.hold, args.mag_every, args.clip, args.mag_scale, offset,
                args.start_in_motion, args.seed, args.drop_batches, args.batch, bursts, args.fill)
    write_csv(out, args.out)
    print(f"{args.out}: {len(out['t'])} samples, {out['rate_hz']:.2f} Hz")
    return 0


if __name__ == "__main__":
    sys.exit(main())
