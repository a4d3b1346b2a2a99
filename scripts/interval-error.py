#!/usr/bin/env python3
"""What one gyro rate per interval leaves out of the rotation at a lower rate (docs/broad.md, "A second basin").

The recording is resampled onto a grid at RATE with `attitude_client.alter`'s resampling (each new rate is its
interval's mean, the gyro's integral kept). Each interval's rotation is then taken from that one rate, with the coning
term of the interval before (the service's `gyro.coning`), and compared with the rotation the source's own samples
integrate to over the same interval (the source's rates held over their intervals, as the service takes them).
Printed: the RMS of the per-interval error; the `change_factor` whose `change_factor · |Δω| Δt` has the same RMS; and
the error of the product of WINDOW seconds of intervals (median, 90th percentile, largest), which says how far the
per-interval errors add up in step.

    .venv/bin/python scripts/interval-error.py RECORDING.hdf5|RECORDING.csv [--rate 25] [--window 5]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from attitude_client.alter import resample
from attitude_client.replay import load_trial


def source_rotations(t: np.ndarray, gyr: np.ndarray, times: np.ndarray) -> list[Rotation]:
    """The body-frame rotation over each (times[k−1], times[k]] from the source's piecewise constant rates."""
    dt = np.diff(t)
    edges = np.concatenate([[t[0] - dt[0]], t])
    out = []
    for a, b in zip(times[:-1], times[1:]):
        i = int(np.searchsorted(edges, a, side="right") - 1)
        r, now = Rotation.identity(), a
        while now < b - 1e-12:
            nxt = min(edges[i + 1], b)
            r = r * Rotation.from_rotvec(gyr[i] * (nxt - now))
            now, i = nxt, i + 1
        out.append(r)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("recording", type=Path)
    ap.add_argument("--rate", type=float, default=25.0, help="the lower rate, Hz (default 25)")
    ap.add_argument("--window", type=float, default=5.0, help="the span over which errors add up, s (default 5)")
    a = ap.parse_args()
    trial = load_trial(a.recording, None)
    t = np.asarray(trial["t"], dtype=float)
    dt = 1.0 / a.rate
    times = np.arange(t[0] + dt, t[-1], dt)
    m = resample(trial, times)["gyr"]
    truth = source_rotations(t, np.asarray(trial["gyr"], dtype=float), times)
    # Interval k (k ≥ 1) from its mean rate and the coning term of the interval before, as the service integrates.
    est = [Rotation.from_rotvec(m[k] * dt + np.cross(m[k - 1], m[k]) * dt * dt / 12.0) for k in range(1, len(times))]
    per = np.array([(e.inv() * r).magnitude() for e, r in zip(est, truth)])
    change = np.linalg.norm(m[1:] - m[:-1], axis=1) * dt
    factor = np.sqrt(np.mean(per**2) / np.mean(change**2))
    w = max(1, int(round(a.window * a.rate)))
    spans = []
    for s0 in range(0, len(est) - w, max(1, w // 2)):
        re, rt = Rotation.identity(), Rotation.identity()
        for k in range(s0, s0 + w):
            re, rt = re * est[k], rt * truth[k]
        spans.append((re.inv() * rt).magnitude())
    spans = np.degrees(spans)
    print(f"{a.recording.name} at {a.rate:g} Hz: per interval {np.degrees(np.sqrt(np.mean(per**2))):.4f}° RMS; "
          f"change_factor of the same RMS {factor:.4f}; over {a.window:g} s: median {np.median(spans):.2f}°, "
          f"90th percentile {np.percentile(spans, 90):.2f}°, largest {spans.max():.2f}°")


if __name__ == "__main__":
    main()
