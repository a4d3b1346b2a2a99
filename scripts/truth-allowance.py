#!/usr/bin/env python3
"""The truth's own tilt error of recordings, measured where the accelerometer is the best tilt reference there is: at
rest, it measures gravity (and its own small error). Per rest period (the gyro within 0.03 rad/s of its opening
median for at least 0.5 s), the angle between the accelerometer's mean direction and the truth's vertical (carried
into VQF's frames for a truth with its own frames, `align: both`, docs/recordings.md). The per-axis 1σ, RMS/√2, is
the allowance the scores add for the truth (`truth_tilt_sigma_deg`).

Beside it, the truth's short-term consistency with the gyro, at rest and in motion: over windows of 0.2 s the
rotation the gyro integrates (its rest median taken as its bias) against the rotation of the truth carried into the
IMU's body axes, as a 3-axis angle. Over 0.2 s a MEMS gyro's own error is a few hundredths of a degree, so what
this shows is the truth's (marker noise and glitches, a mount that is not rigid, time stamps off): calm (the gyro
under 30 °/s throughout the window) and moving. It is a measurement to read beside the allowance (where the truth
is far worse in motion than at rest, no estimator's error can be scored as finely there), not an allowance itself.

Two more measures say whether that disagreement in motion is the sensor's or the truth's time stamps: the truth's
**time lag** behind the gyro (the shift of the truth that best matches the rotation angles over windows of 0.1 s in
motion, a rate taken to cover the interval before its time stamp; searched over ±60 ms by 0.5 ms) and the gyro's
**scale** against the truth (the median ratio of the truth's rotation angle to the gyro's over the windows that
turn more than 10°: 1 for a gyro whose scale factor is right).

    .venv/bin/python scripts/truth-allowance.py RECORDING.hdf5|RECORDING.csv [...]
"""
import sys

import numpy as np

from attitude_client.replay import alignment, invquat, load_trial, quatmult, rotation_matrix, run_vqf


def rests(g, rate, thr=0.03, min_s=0.5):
    still = np.linalg.norm(g - np.median(g[:max(5,int(rate))],0),axis=1) < thr
    out=[]; k=0; n=len(g)
    while k<n:
        if still[k]:
            j=k
            while j<n and still[j]: j+=1
            if (j-k)/rate>=min_s: out.append((k,j))
            k=j
        else: k+=1
    return out
def expq(v):
    """Unit quaternions [w, x, y, z] of rotation vectors (rows)."""
    a = np.linalg.norm(v, axis=1)
    k = np.where(a > 1e-12, np.sin(a / 2) / np.maximum(a, 1e-300), 0.5)
    return np.column_stack([np.cos(a / 2), v * k[:, None]])


def gyro_attitude(tr):
    """The gyro's integral from the first sample, its rest median taken as its bias (a rate covers the interval
    before its time stamp): unit quaternions per sample."""
    g = tr["gyr"]; t = tr["t"]; n = len(g)
    rs = rests(g, tr["rate_hz"])
    bias = np.median(np.concatenate([g[k:j] for k, j in rs]), axis=0) if rs else np.zeros(3)
    steps = expq((g[1:] - bias) * np.diff(t)[:, None])
    cum = np.empty((n, 4)); cum[0] = [1, 0, 0, 0]
    for k in range(1, n):
        cum[k] = quatmult(cum[k - 1][None], steps[k - 1][None])[0]
    return cum


def consistency(tr, qt_body, window_s=0.2, calm_rad_s=np.radians(30)):
    """3-axis angles (deg) between the gyro's and the truth's rotation over windows of ``window_s`` (half
    overlapping, truth known at both ends), and whether each window is calm."""
    g = tr["gyr"]; n = len(g)
    cum = gyro_attitude(tr)
    w = max(1, int(round(window_s * tr["rate_hz"])))
    known = np.isfinite(qt_body).all(1) & tr["movement"]
    s = np.arange(0, n - w, max(1, w // 2))
    s = s[known[s] & known[s + w]]
    if not len(s):
        return np.zeros(0), np.zeros(0, dtype=bool)
    gyro = quatmult(invquat(cum[s]), cum[s + w])
    truth = quatmult(invquat(qt_body[s]), qt_body[s + w])
    e = quatmult(invquat(truth), gyro)
    ang = np.degrees(turn(e))
    peak = np.array([np.abs(g[a:a + w + 1]).max() for a in s])
    return ang, peak < calm_rad_s


def angle_pairs(tr, qt_body, window_s=0.1, min_deg=0.0):
    """Per window of ``window_s`` in motion (half overlapping, truth known at both ends): the gyro's rotation angle
    (rad; its rest median as its bias) and a function giving the truth's over the same window shifted by a lag (s),
    with whether the shifted window lies within the truth's samples."""
    t = tr["t"]; n = len(t)
    cum = gyro_attitude(tr)
    w = max(2, int(round(window_s * tr["rate_hz"])))
    ok = np.isfinite(qt_body).all(1)
    known = ok & tr["movement"]
    s = np.arange(0, n - w, max(1, w // 2))
    s = s[known[s] & known[s + w]]
    ag = turn(quatmult(invquat(cum[s]), cum[s + w]))
    keep = ag >= np.radians(min_deg)
    s, ag = s[keep], ag[keep]
    tk, qk = t[ok], qt_body[ok].copy()
    # (One sign along the recording: a quaternion and its negative interpolate through zero.)
    for k in range(1, len(qk)):
        if qk[k] @ qk[k - 1] < 0:
            qk[k] = -qk[k]

    def truth_at(x):
        q = np.column_stack([np.interp(x, tk, qk[:, j]) for j in range(4)])
        return q / np.linalg.norm(q, axis=1)[:, None]

    def truth_angles(lag):
        inside = (t[s] + lag >= tk[0]) & (t[s + w] + lag <= tk[-1])
        return turn(quatmult(invquat(truth_at(t[s] + lag)), truth_at(t[s + w] + lag))), inside

    return ag, truth_angles


def turn(d):
    """Rotation angles (rad) of quaternions (rows)."""
    return 2 * np.arctan2(np.linalg.norm(d[:, 1:], axis=1), np.abs(d[:, 0]))


def time_lag(tr, qt_body, max_s=0.06, step_s=0.0005):
    """The truth's lag behind the gyro (s): the shift of the truth's time stamps that best matches the rotation
    angles over 0.1 s windows in motion (least squares over the shifts ±max_s)."""
    ag, truth_angles = angle_pairs(tr, qt_body)
    best = (float("inf"), 0.0)
    for lag in np.arange(-max_s, max_s + step_s / 2, step_s):
        at, inside = truth_angles(lag)
        if inside.sum() > 10:
            best = min(best, (float(np.mean((at[inside] - ag[inside]) ** 2)), float(lag)))
    return best[1]


def gyro_scale(tr, qt_body, lag=0.0):
    """The median ratio of the truth's rotation angle to the gyro's over 0.1 s windows turning more than 10°."""
    ag, truth_angles = angle_pairs(tr, qt_body, min_deg=10.0)
    at, inside = truth_angles(lag)
    return float(np.median(at[inside] / ag[inside])) if inside.any() else float("nan")


def rms(x):
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


def main(paths):
    allerr = []
    calm_all = []
    moving_all = []
    for p in paths:
        tr = load_trial(p, None)
        q = run_vqf(tr)
        truth = tr["opt_quat"]
        ok = tr["movement"] & np.isfinite(truth).all(1)
        if tr["truth"]["align"] == "both":
            l, r = alignment(q[ok], truth[ok])
            qt = quatmult(quatmult(invquat(l), truth), invquat(r))
        else:
            qt = truth
        ang, calm = consistency(tr, qt)
        calm_all += list(ang[calm])
        moving_all += list(ang[~calm])
        R = rotation_matrix(qt)
        up_body = np.einsum("nji,j->ni", R, np.array([0, 0, 1.0]))
        errs = []
        for k, j in rests(tr["gyr"], tr["rate_hz"]):
            a = tr["acc"][k:j].mean(0)
            u = np.nanmean(up_body[k:j], 0)
            if not np.isfinite(u).all():
                continue
            u /= np.linalg.norm(u)
            a /= np.linalg.norm(a)
            errs.append(np.rad2deg(np.arccos(np.clip(a @ u, -1, 1))))
        allerr += errs
        print(f"{tr['name'][:36]:36s} rests {len(errs)} tilt acc-vs-truth deg {np.round(errs, 2)}")
        p99 = np.percentile(ang, 99) if len(ang) else float("nan")
        print(f"{'':36s} gyro-vs-truth over 0.2 s, 3-axis RMS deg: calm {rms(ang[calm]):.2f} ({calm.sum()} windows), "
              f"moving {rms(ang[~calm]):.2f} ({(~calm).sum()}), 99th percentile {p99:.2f}")
        lag = time_lag(tr, qt)
        print(f"{'':36s} truth's lag behind the gyro {lag * 1e3:+.1f} ms; truth/gyro turn over 0.1 s "
              f"(turns > 10 deg) {gyro_scale(tr, qt, lag):.4f}")
    e = np.array(allerr)
    print(f"ALL: n {len(e)} rms {rms(e):.2f} per-axis sigma {rms(e) / np.sqrt(2):.2f} "
          f"median {np.median(e) if len(e) else float('nan'):.2f}")
    print(f"ALL gyro-vs-truth over 0.2 s, 3-axis RMS deg: calm {rms(calm_all):.2f} ({len(calm_all)} windows), "
          f"moving {rms(moving_all):.2f} ({len(moving_all)})")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
