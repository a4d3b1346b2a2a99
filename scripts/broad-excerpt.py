#!/usr/bin/env python3
"""Writes the BROAD excerpts committed under tests/data/broad/ (what the Python tests replay).

    .venv/bin/python scripts/broad-excerpt.py [SOURCE_DIR] [--out tests/data/broad]

SOURCE_DIR holds the benchmark's trial files (default ../shared/data/broad). Each excerpt keeps the rows
[first, end) of its source trial in the BROAD layout: the same datasets (`imu_gyr`, `imu_acc`, `imu_mag`,
`opt_quat`, `opt_pos`, `movement`) and attributes (`sampling_rate`, `info`), plus `first_sample` (the source
row of the excerpt's first row: sample k of the excerpt is at t = (first_sample + k) / sampling_rate, the
source trial's own time). The IMU channels and `opt_pos` are stored as float32 (to keep the files small; the
readers convert to float64), `opt_quat` as float64 and `movement` as in the source; every dataset gzip-compressed
with the shuffle filter. tests/data/broad/README.md lists the ranges and why they were chosen.

Data: BROAD (D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial Orientation
Estimation", Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent

#: name: (source trial, first row, end row (exclusive)); at 2000/7 Hz, 2000 rows are 7 s.
EXCERPTS = {
    # 20.0–95.0 s: the last 15.3 s of the opening rest (movement starts at row 10081, 35.28 s), then 59.7 s of
    # fast translations.
    "16_undisturbed_fast_translation_B_excerpt": ("16_undisturbed_fast_translation_B", 5714, 27143),
    # 28.0–110.0 s: 16.8 s of rest, the magnet attached at about 44.8 s (the board is handled: the flag
    # `movement` starts at 48.27 s), carried until about 99.5 s, then 10 s without it.
    "34_disturbed_attached_magnet_3cm_excerpt": ("34_disturbed_attached_magnet_3cm", 8000, 31429),
}
FLOAT32 = ("imu_gyr", "imu_acc", "imu_mag", "opt_pos")


def write_excerpt(source: Path, first: int, end: int, target: Path) -> None:
    with h5py.File(source, "r") as f, h5py.File(target, "w") as out:
        n = len(f["imu_gyr"])
        if not 0 <= first < end <= n:
            raise SystemExit(f"{source}: rows [{first}, {end}) outside its {n} rows")
        for name in ("imu_gyr", "imu_acc", "imu_mag", "opt_quat", "opt_pos", "movement"):
            data = f[name][first:end]
            if name in FLOAT32:
                data = data.astype(np.float32)
            out.create_dataset(name, data=data, compression="gzip", compression_opts=9, shuffle=True)
        out.attrs["sampling_rate"] = f.attrs["sampling_rate"]
        out.attrs["first_sample"] = np.int64(first)
        out.attrs["source"] = f"{source.name}, rows [{first}, {end})"
        out.attrs["info"] = (
            f"Excerpt of {source.name}: rows [{first}, {end}) (sample k at t = (first_sample + k) / sampling_rate);"
            " imu_* and opt_pos stored as float32.\n\n" + str(f.attrs.get("info", ""))
        )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", nargs="?", type=Path, default=ROOT.parent / "shared" / "data" / "broad")
    ap.add_argument("--out", type=Path, default=ROOT / "tests" / "data" / "broad")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name, (trial, first, end) in EXCERPTS.items():
        target = args.out / f"{name}.hdf5"
        write_excerpt(args.source / f"{trial}.hdf5", first, end, target)
        print(f"{target}: rows [{first}, {end}) of {trial}, {target.stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
