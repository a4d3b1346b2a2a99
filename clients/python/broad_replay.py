#!/usr/bin/env python3
"""Replays a recorded IMU trial (BROAD benchmark HDF5) through a running attitude-service and scores it.

    attitude-service serve --config config/imu.json5 --listen tcp/127.0.0.1:7447      # the user runs this
    python clients/python/broad_replay.py TRIAL.hdf5 --connect tcp/127.0.0.1:7447 [--json]

What it does (it never starts the service):

1. Reads the trial with h5py: ``imu_gyr`` (rad/s), ``imu_acc`` (m/s²), ``imu_mag`` (µT), ``opt_quat`` ([w,x,y,z], the
   sensor in an East-North-Up frame aligned with magnetic north; NaN rows where the cameras lost the markers),
   ``movement`` (bool), attribute ``sampling_rate``. Sample k is at ``t_k = k / rate``. Your own recording works if
   it has these datasets (``opt_quat`` and ``movement`` only for scoring).
2. Derives the references from the data, never from ``opt_quat``: over the first ``--rest-seconds`` (the trial must
   open at rest) the mean accelerometer norm ``g0``, the mean magnetometer norm ``m0`` and the dip ``δ`` (the angle
   between the mean accelerometer and the mean magnetometer reading, minus 90°). Gravity reference ``[0, 0, g0]``
   (up), field reference ``m0·[0, cos δ, −sin δ]`` (ENU, magnetic north).
3. Streams the trial into one vehicle per ``--filters`` entry, one vehicle after the other, (each configured by a reset request, e.g.
   ``{"filter": "qpf", "fiducial": "average", "particles": N}``) with its recorded timestamps, as fast as the service
   takes it: batches of ``--batch`` samples (spanning less than the service's reorder window, 0.2 s by default:
   gyro and vectors travel on different keys, and a gyro batch that runs further ahead releases its samples before
   the vectors of the same span arrive, which are then refused as out of order), one gyro batch (sample k's rate covers ``(t_{k−1}, t_k]``, so it is
   stamped ``t_{k−1}``) then one vector batch (``{"t": t_k, "obs": [acc, mag]}`` with sensor names ``acc`` and
   ``mag``, σ = 0.05·g0 and 0.07·m0: the direction σ in rad times the reference norm), in time order. Flow control:
   at most ``--window`` samples per vehicle are in flight (sent, no estimate yet); rejections on ``P/V/rejected``
   are counted (a ``queue_full`` means the window is too large for the service's ``queue_per_vehicle``).
4. Collects one estimate per vector set (matched by ``t``; a set without one, e.g. lost, takes the previous
   estimate), runs VQF (PyPI ``vqf``, 9D) and Madgwick (PyPI ``ahrs``, MARG, gain β = 0.12, BROAD's TAGP value for
   Madgwick) on the same samples, and scores everything with BROAD's metric (``example_code/broad_utils.py``
   ``calculateRMSE``): ``e = q_est ⊗ q_opt⁻¹``, total ``2·acos|e_w|``, heading ``2·atan|e_z/e_w|``, inclination
   ``2·acos√(e_w² + e_z²)``, RMSE in degrees over the ``movement`` samples, NaN truth rows ignored. No heading
   alignment is applied (the benchmark applies none: ``opt_quat``'s frame is aligned with magnetic north).

Output: a table, or with ``--json`` one object mapping each estimator (``mekf``, ``qpf:average``, ``vqf``,
``madgwick``) to ``{"total_rmse_deg", "heading_rmse_deg", "inclination_rmse_deg"}``. ``--details FILE`` writes the
run's particulars (references, timings, counts) as JSON.

Data: BROAD (D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial Orientation
Estimation", Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import zenoh

sys.path.insert(0, str(Path(__file__).resolve().parent))
from attitude_client import AttitudeClient  # noqa: E402

ATTRIBUTION = (
    "Data: BROAD (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0."
)
#: Direction 1σ of the accelerometer and the magnetometer at their reference norms, rad (config/imu.json5).
SIGMA_ACC_RAD = 0.05
SIGMA_MAG_RAD = 0.07
#: Madgwick's gain: BROAD's TAGP parameter for Madgwick (published_madgwick_rmse.json).
MADGWICK_BETA = 0.12

# ---------------------------------------------------------------------------------------------------
# Quaternions, Hamilton [w, x, y, z]; the metric of broad_utils.py


def quatmult(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    q1, q2 = np.atleast_2d(q1), np.atleast_2d(q2)
    w1, x1, y1, z1 = q1.T
    w2, x2, y2, z2 = q2.T
    return np.column_stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def invquat(q: np.ndarray) -> np.ndarray:
    out = np.array(q, dtype=float, copy=True)
    out[..., 1:] *= -1.0
    return out


def broad_rmse(q_est: np.ndarray, q_opt: np.ndarray, movement: np.ndarray) -> dict:
    """BROAD's calculateRMSE: total/heading/inclination RMSE in degrees over ``movement``."""
    q_est = q_est / np.linalg.norm(q_est, axis=1)[:, None]
    q_opt = q_opt / np.linalg.norm(q_opt, axis=1)[:, None]
    e = quatmult(q_est, invquat(q_opt))
    e = e / np.linalg.norm(e, axis=1)[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        total = 2.0 * np.arccos(np.clip(np.abs(e[:, 0]), 0.0, 1.0))
        heading = 2.0 * np.arctan(np.abs(e[:, 3] / e[:, 0]))
        incl = 2.0 * np.arccos(np.clip(np.sqrt(e[:, 0] ** 2 + e[:, 3] ** 2), 0.0, 1.0))

    def rmse(x: np.ndarray) -> float:
        return float(np.rad2deg(np.sqrt(np.nanmean(x[movement] ** 2))))

    return {"total_rmse_deg": rmse(total), "heading_rmse_deg": rmse(heading), "inclination_rmse_deg": rmse(incl)}


# ---------------------------------------------------------------------------------------------------
# Data


def load_trial(path: Path, excerpt_seconds: float | None) -> dict:
    with h5py.File(path, "r") as f:
        trial = {
            "name": path.stem,
            "gyr": np.ascontiguousarray(f["imu_gyr"][:], dtype=np.float64),
            "acc": np.ascontiguousarray(f["imu_acc"][:], dtype=np.float64),
            "mag": np.ascontiguousarray(f["imu_mag"][:], dtype=np.float64),
            "opt_quat": np.asarray(f["opt_quat"][:], dtype=np.float64) if "opt_quat" in f else None,
            "movement": np.asarray(f["movement"][:], dtype=bool) if "movement" in f else None,
            "rate_hz": float(f.attrs["sampling_rate"]),
        }
    n = len(trial["gyr"])
    for key in ("gyr", "acc", "mag"):
        if trial[key].shape != (n, 3) or not np.isfinite(trial[key]).all():
            raise SystemExit(f"{path}: imu_{key} must be {n}×3 finite values")
    if excerpt_seconds is not None:
        start = int(np.argmax(trial["movement"])) if trial["movement"] is not None and trial["movement"].any() else 0
        end = min(n, start + int(round(excerpt_seconds * trial["rate_hz"])))
        for key in ("gyr", "acc", "mag", "opt_quat", "movement"):
            if trial[key] is not None:
                trial[key] = trial[key][:end]
    trial["t"] = np.arange(len(trial["gyr"]), dtype=np.float64) / trial["rate_hz"]
    return trial


def references(trial: dict, rest_seconds: float) -> dict:
    """g0, m0 and the dip from the opening rest period (the data only, never the truth)."""
    k = max(1, min(len(trial["acc"]), int(round(rest_seconds * trial["rate_hz"]))))
    acc, mag = trial["acc"][:k], trial["mag"][:k]
    g0 = float(np.mean(np.linalg.norm(acc, axis=1)))
    m0 = float(np.mean(np.linalg.norm(mag, axis=1)))
    a, m = acc.mean(axis=0), mag.mean(axis=0)
    angle = float(np.arccos(np.clip(a @ m / (np.linalg.norm(a) * np.linalg.norm(m)), -1.0, 1.0)))
    dip = angle - np.pi / 2
    return {
        "g0": g0,
        "m0": m0,
        "dip_deg": float(np.rad2deg(dip)),
        "gravity_ref": [0.0, 0.0, g0],
        "field_ref": [0.0, m0 * float(np.cos(dip)), -m0 * float(np.sin(dip))],
        "rest_samples": k,
    }


# ---------------------------------------------------------------------------------------------------
# Through the service


def reset_fields(spec: str, particles: int) -> dict:
    kind, _, fiducial = spec.partition(":")
    fields = {"filter": kind}
    if kind != "mekf":
        fields["fiducial"] = fiducial or "average"
    if kind == "qpf":
        fields["particles"] = particles
    return fields


def replay(client: AttitudeClient, trial: dict, refs: dict, specs: list[str], args) -> dict:
    """Streams the trial into one vehicle per spec; returns {spec: {"quat": (n, 4), ...}}."""
    n, t, rate = len(trial["gyr"]), trial["t"], trial["rate_hz"]
    tag = args.tag or f"{os.getpid()}-{int(time.time() * 1000) % 1_000_000}"
    vehicles = {spec: f"{args.vehicle_prefix}-{spec.replace(':', '-')}-{tag}" for spec in specs}
    by_vehicle = {v: s for s, v in vehicles.items()}
    lock = threading.Lock()
    cond = threading.Condition(lock)
    quats = {s: np.full((n, 4), np.nan) for s in specs}
    got = {s: 0 for s in specs}
    newest = {s: -1 for s in specs}
    rejected: dict[str, dict[str, int]] = {s: {} for s in specs}
    last_estimate: dict[str, dict] = {}

    def on_estimate(msg: dict) -> None:
        spec = by_vehicle.get(msg.get("vehicle"))
        if spec is None:
            return
        i = int(round(msg["t"] * rate))
        if not (0 <= i < n) or abs(msg["t"] - t[i]) > 1e-6:
            return
        q = msg["q"]
        with cond:
            if np.isnan(quats[spec][i, 0]):
                got[spec] += 1
            quats[spec][i] = [q["w"], q["x"], q["y"], q["z"]]
            newest[spec] = max(newest[spec], i)
            last_estimate[spec] = msg
            cond.notify_all()

    def on_rejected(msg: dict) -> None:
        key = msg.get("key", "")
        parts = key.split("/")
        vehicle = parts[-2] if len(parts) >= 2 else ""
        spec = by_vehicle.get(vehicle)
        if spec is None:
            return
        with cond:
            code = msg.get("code", "?")
            rejected[spec][code] = rejected[spec].get(code, 0) + 1
            cond.notify_all()

    # The estimates are queued by zenoh itself (a FIFO channel, no Python callback on zenoh's thread) and
    # drained by a thread of ours: a callback that waits for the interpreter while the main thread encodes
    # batches makes the service's publisher block, and zenoh closes a transport that stays blocked.
    estimate_subs = [
        client.session.declare_subscriber(client.key(v, "estimate"), zenoh.handlers.FifoChannel(1 << 18))
        for v in vehicles.values()
    ]
    stop = threading.Event()

    def drain() -> None:
        while not stop.is_set():
            idle = True
            for sub in estimate_subs:
                while True:
                    try:
                        sample = sub.try_recv()
                    except zenoh.ZError:  # closed: the session is going away
                        return
                    if sample is None:
                        break
                    idle = False
                    try:
                        on_estimate(json.loads(sample.payload.to_bytes()))
                    except (ValueError, KeyError, TypeError):
                        pass
            if idle:
                time.sleep(0.001)

    drainer = threading.Thread(target=drain, name="estimates", daemon=True)
    drainer.start()
    subs = [client.subscribe_rejections(on_rejected)]
    for spec, vehicle in vehicles.items():
        client.reset(vehicle, **reset_fields(spec, args.particles))
    time.sleep(0.2)  # let the subscriptions reach the service

    acc_sigma = SIGMA_ACC_RAD * refs["g0"]
    mag_sigma = SIGMA_MAG_RAD * refs["m0"]
    gyro_t = np.concatenate([[t[0] - 1.0 / rate], t[:-1]])  # rate k covers (t_{k-1}, t_k]
    t0 = time.monotonic()
    sent = 0
    stall_deadline = args.timeout
    for start in range(0, n, args.batch):
        end = min(n, start + args.batch)
        gyro = json.dumps(
            [{"t": float(gyro_t[k]), "omega": trial["gyr"][k].tolist()} for k in range(start, end)]
        )
        vectors = json.dumps(
            [
                {
                    "t": float(t[k]),
                    "obs": [
                        {"sensor": "acc", "body": trial["acc"][k].tolist(), "ref": refs["gravity_ref"],
                         "sigma": acc_sigma},
                        {"sensor": "mag", "body": trial["mag"][k].tolist(), "ref": refs["field_ref"],
                         "sigma": mag_sigma},
                    ],
                }
                for k in range(start, end)
            ]
        )
        for spec, vehicle in vehicles.items():
            # Flow control: wait until the estimates are within `window` samples of what is sent.
            deadline = time.monotonic() + stall_deadline
            with cond:
                while start - (newest[spec] + 1) > args.window:
                    if not cond.wait(timeout=max(0.0, deadline - time.monotonic())):
                        raise SystemExit(
                            f"{spec}: no estimate progress for {stall_deadline} s at sample {newest[spec]}"
                            f" (rejections {rejected[spec]})"
                        )
            client.put_raw(vehicle, "gyro", gyro)
            client.put_raw(vehicle, "vectors", vectors)
        sent = end
    # The last sets leave the reorder window by wall time.
    # Wait for the last estimates until every set has one, or none came for `quiet` s (a refused set never will).
    quiet = 3.0
    for spec in specs:
        with cond:
            while newest[spec] < sent - 1:
                before = got[spec]
                cond.wait(timeout=quiet)
                if got[spec] == before:
                    break
    seconds = time.monotonic() - t0
    stop.set()
    drainer.join(timeout=5)
    for s in subs + estimate_subs:
        s.undeclare()
    out = {}
    for spec in specs:
        q = quats[spec]
        missing = int(np.isnan(q[:, 0]).sum())
        # A set without an estimate takes the previous one (causal); none before the first.
        ok = ~np.isnan(q[:, 0])
        idx = np.where(ok, np.arange(n), 0)
        np.maximum.accumulate(idx, out=idx)
        filled = q[idx]
        filled[: int(np.argmax(ok))] = np.nan if ok.any() else filled[:0]
        diag = last_estimate.get(spec, {}).get("diagnostics", {})
        out[spec] = {
            "quat": filled,
            "vehicle": vehicles[spec],
            "estimates": got[spec],
            "missing": missing,
            "rejected": rejected[spec],
            "seconds": seconds,
            "samples_per_s": n / seconds if seconds > 0 else None,
            "sensor_counts": diag.get("gate"),
        }
    return out


# ---------------------------------------------------------------------------------------------------
# Peers


def run_vqf(trial: dict) -> np.ndarray:
    from vqf import VQF

    return VQF(1.0 / trial["rate_hz"]).updateBatch(trial["gyr"], trial["acc"], trial["mag"])["quat9D"]


def run_madgwick(trial: dict) -> np.ndarray:
    """ahrs' Madgwick MARG filter. Its earth frame is North-West-Up (x to magnetic north, z up); rotated by +90°
    about up into East-North-Up."""
    from ahrs.filters import Madgwick

    q = Madgwick(
        gyr=trial["gyr"], acc=trial["acc"], mag=trial["mag"], frequency=trial["rate_hz"], gain=MADGWICK_BETA
    ).Q
    rz = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
    return quatmult(rz, q)


# ---------------------------------------------------------------------------------------------------


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trial", type=Path, help="a BROAD trial (.hdf5) or a recording with the same datasets")
    ap.add_argument("--connect", required=True, help="zenoh endpoint of the running service, e.g. tcp/127.0.0.1:7447")
    ap.add_argument("--prefix", default="attitude", help="the service's key prefix (default attitude)")
    ap.add_argument("--json", action="store_true", help="print one JSON object {estimator: {total_rmse_deg, ...}}")
    ap.add_argument("--filters", default="mekf,qpf:average",
                    help="comma-separated filters, one vehicle each (default mekf,qpf:average)")
    ap.add_argument("--particles", type=int, default=500, help="particles of a qpf vehicle (default 500)")
    ap.add_argument("--excerpt-seconds", type=float,
                    help="replay only the opening rest and this many seconds from the first movement sample")
    ap.add_argument("--rest-seconds", type=float, default=1.0,
                    help="opening rest period the references are taken from (default 1 s)")
    ap.add_argument("--batch", type=int, default=40,
                    help="samples per put (default 40 = 0.14 s at 286 Hz; a batch must span less than the "
                         "service's reorder window, 0.2 s by default, or the gyro batch runs ahead of the vectors)")
    ap.add_argument("--window", type=int, default=2000,
                    help="most samples per vehicle sent ahead of its estimates (default 2000)")
    ap.add_argument("--timeout", type=float, default=60.0, help="longest wait without progress, s (default 60)")
    ap.add_argument("--vehicle-prefix", default="broad", help="vehicle ids are PREFIX-FILTER-TAG (default broad)")
    ap.add_argument("--tag", help="TAG of the vehicle ids (default: from the process id and the clock). A particle "
                                  "filter's seed derives from its vehicle id: a fixed tag on a fresh service "
                                  "repeats a run. Every replay needs vehicle ids new to the service (an id already used "
                                  "refuses the replay's times as old): give each trial its own tag")
    ap.add_argument("--no-peers", action="store_true", help="skip VQF and Madgwick")
    ap.add_argument("--details", type=Path, help="write the run's particulars here (JSON)")
    args = ap.parse_args()
    if args.batch < 1 or args.window < args.batch or args.particles < 1:
        ap.error("--batch must be ≥ 1, --window ≥ --batch, --particles ≥ 1")

    trial = load_trial(args.trial, args.excerpt_seconds)
    if trial["opt_quat"] is None or trial["movement"] is None or not trial["movement"].any():
        raise SystemExit(f"{args.trial}: needs opt_quat and movement samples to score")
    refs = references(trial, args.rest_seconds)
    specs = [s.strip() for s in args.filters.split(",") if s.strip()]

    with AttitudeClient(args.connect, prefix=args.prefix, timeout=10.0) as client:
        client.wait_for_service(timeout=20.0)
        # One vehicle after the other: on a small machine a particle filter running beside the MEKF delays the
        # service's dispatch enough that samples leave the reorder window by wall time, out of order.
        runs = {}
        for spec in specs:
            runs.update(replay(client, trial, refs, [spec], args))

    results = {spec: broad_rmse(run["quat"], trial["opt_quat"], trial["movement"]) for spec, run in runs.items()}
    peer_seconds = {}
    if not args.no_peers:
        for name, fn in (("vqf", run_vqf), ("madgwick", run_madgwick)):
            t0 = time.perf_counter()
            q = fn(trial)
            peer_seconds[name] = time.perf_counter() - t0
            results[name] = broad_rmse(q, trial["opt_quat"], trial["movement"])

    if args.details:
        details = {
            "trial": trial["name"],
            "samples": len(trial["gyr"]),
            "rate_hz": trial["rate_hz"],
            "references": refs,
            "particles": args.particles,
            "batch": args.batch,
            "window": args.window,
            "service": {s: {k: v for k, v in r.items() if k != "quat"} for s, r in runs.items()},
            "peer_seconds": peer_seconds,
            "results": results,
            "attribution": ATTRIBUTION,
        }
        args.details.write_text(json.dumps(details, indent=2))

    for spec, run in runs.items():
        if run["rejected"] or run["missing"]:
            print(f"warning: {spec}: rejections {run['rejected']}, {run['missing']} sets without an estimate",
                  file=sys.stderr)
    if args.json:
        print(json.dumps(results))
        return 0
    print(f"{trial['name']}: {len(trial['gyr'])} samples at {trial['rate_hz']:.3f} Hz; dip {refs['dip_deg']:.1f}°, "
          f"g0 {refs['g0']:.3f} m/s², m0 {refs['m0']:.2f}")
    print(f"{'estimator':<14} {'total°':>8} {'heading°':>9} {'incl.°':>8}   notes")
    for name, r in results.items():
        note = ""
        if name in runs:
            run = runs[name]
            note = f"through the service, {run['samples_per_s']:.0f} samples/s"
            if name.startswith("qpf"):
                note += f", {args.particles} particles"
        print(f"{name:<14} {r['total_rmse_deg']:>8.2f} {r['heading_rmse_deg']:>9.2f} "
              f"{r['inclination_rmse_deg']:>8.2f}   {note}")
    print("BROAD RMSE over `movement` (broad_utils.calculateRMSE, no heading alignment). " + ATTRIBUTION)
    return 0


if __name__ == "__main__":
    sys.exit(main())
