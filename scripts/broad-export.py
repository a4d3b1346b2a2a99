#!/usr/bin/env python3
"""Exports BROAD trials (HDF5) into the trial files of `attitude-service imu-study` and `imu-bench`.

    .venv/bin/python scripts/broad-export.py TRIAL.hdf5 [...] --out DIR

Trial file (little-endian float64 throughout): a header `[n, rate_hz, 15]`, then per sample
`[t, gx, gy, gz, ax, ay, az, mx, my, mz, qw, qx, qy, qz, movement]`: time (s, (first_sample + k) / rate, with
the optional attribute `first_sample` of an excerpt, tests/data/broad/README.md; 0 when absent), gyro (rad/s),
accelerometer (m/s²), magnetometer (µT), the optical truth (Hamilton, body → East-North-Up with magnetic
north; NaN where the cameras lost the markers, or for a recording without truth) and the benchmark's
`movement` flag (1/0). Files are named after the trial (`DIR/NAME.trial`).

Data: BROAD (D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial Orientation
Estimation", Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

COLUMNS = 15


def export(path: Path, out: Path) -> Path:
    with h5py.File(path, "r") as f:
        gyr = np.asarray(f["imu_gyr"][:], dtype=np.float64)
        acc = np.asarray(f["imu_acc"][:], dtype=np.float64)
        mag = np.asarray(f["imu_mag"][:], dtype=np.float64)
        n = len(gyr)
        quat = np.asarray(f["opt_quat"][:], dtype=np.float64) if "opt_quat" in f else np.full((n, 4), np.nan)
        movement = np.asarray(f["movement"][:], dtype=np.float64) if "movement" in f else np.zeros(n)
        rate = float(f.attrs["sampling_rate"])
        first = int(f.attrs.get("first_sample", 0))
    for name, a in (("imu_gyr", gyr), ("imu_acc", acc), ("imu_mag", mag)):
        if a.shape != (n, 3) or not np.isfinite(a).all():
            raise SystemExit(f"{path}: {name} must be {n}×3 finite values")
    t = (first + np.arange(n, dtype=np.float64)) / rate
    body = np.column_stack([t, gyr, acc, mag, quat, movement.reshape(n, 1)])
    target = out / f"{path.stem}.trial"
    with open(target, "wb") as fh:
        fh.write(np.array([n, rate, COLUMNS], dtype="<f8").tobytes())
        fh.write(np.ascontiguousarray(body, dtype="<f8").tobytes())
    return target


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trials", nargs="+", type=Path)
    ap.add_argument("--out", required=True, type=Path)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for p in args.trials:
        print(export(p, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
