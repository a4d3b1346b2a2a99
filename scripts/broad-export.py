#!/usr/bin/env python3
"""Exports BROAD trials (HDF5) into the trial files of `attitude-lab imu-study` and `imu-bench`.

    .venv/bin/python scripts/broad-export.py TRIAL.hdf5 [...] --out DIR [--csv]
        [--truth-tilt-sigma-deg S] [--truth-time-sigma-s S]

Trial file (little-endian float64 throughout): a header `[n, rate_hz, 15]`, then per sample
`[t, gx, gy, gz, ax, ay, az, mx, my, mz, qw, qx, qy, qz, movement]`: time (s, (first_sample + k) / rate, with
the optional attribute `first_sample` of an excerpt, tests/data/broad/README.md; 0 when absent), gyro (rad/s),
accelerometer (m/s²), magnetometer (µT), the optical truth (Hamilton, body → East-North-Up with magnetic
north; NaN where the cameras lost the markers, or for a recording without truth) and the benchmark's
`movement` flag (1/0), then, when the truth is not BROAD's, its description as a JSON object: `align`
(the file's attribute `align`, "both" when the truth has its own reference and body frames) and the
truth's own errors (`truth_tilt_sigma_deg`, `truth_time_sigma_s`: the options, else the file's attributes
of those names). Files are named after the trial (`DIR/NAME.trial`); with `--csv` the same as a CSV trial
(`DIR/NAME.csv`, docs/recordings.md).

Data: BROAD (D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial Orientation
Estimation", Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import h5py
import numpy as np

COLUMNS = 15


CSV_COLUMNS = ["t", "gx", "gy", "gz", "ax", "ay", "az", "mx", "my", "mz", "qw", "qx", "qy", "qz", "movement"]


def export(path: Path, out: Path, csv: bool = False, tilt: float | None = None, time: float | None = None) -> Path:
    meta: dict = {}
    with h5py.File(path, "r") as f:
        align = f.attrs.get("align")
        if align is not None:
            meta["align"] = align.decode() if isinstance(align, bytes) else str(align)
        for key, given in (("truth_tilt_sigma_deg", tilt), ("truth_time_sigma_s", time)):
            value = given if given is not None else f.attrs.get(key)
            if value is not None:
                meta[key] = float(value)
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
    if csv:
        target = out / f"{path.stem}.csv"
        with open(target, "w") as fh:
            for k, v in meta.items():
                fh.write(f"# {k}: {v}\n")
            fh.write(",".join(CSV_COLUMNS) + "\n")
            for row in body:
                fields = ["" if not np.isfinite(x) else repr(float(x)) for x in row[:14]]
                fields.append(str(int(row[14])))
                fh.write(",".join(fields) + "\n")
        return target
    target = out / f"{path.stem}.trial"
    with open(target, "wb") as fh:
        fh.write(np.array([n, rate, COLUMNS], dtype="<f8").tobytes())
        fh.write(np.ascontiguousarray(body, dtype="<f8").tobytes())
        if meta:
            fh.write(json.dumps(meta).encode())
    return target


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trials", nargs="+", type=Path)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--csv", action="store_true", help="write CSV trials instead of binary ones")
    ap.add_argument("--truth-tilt-sigma-deg", type=float, help="the truth's own tilt error, 1σ deg")
    ap.add_argument("--truth-time-sigma-s", type=float, help="the truth's time-stamp uncertainty, 1σ s")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for p in args.trials:
        print(export(p, args.out, args.csv, args.truth_tilt_sigma_deg, args.truth_time_sigma_s))
    return 0


if __name__ == "__main__":
    sys.exit(main())
