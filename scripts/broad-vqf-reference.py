#!/usr/bin/env python3
"""VQF's RMSEs on BROAD trials: the reference the tuning objective compares each trial with
(config/imu-tuning.json5, `reference`).

    .venv/bin/python scripts/broad-vqf-reference.py ../shared/data/broad/*.hdf5 --out config/imu-tuning-vqf.json

VQF 2.x (PyPI `vqf`, Laidig & Seel 2023) with its defaults, online (`updateBatch`, 9D), scored with the metric of
attitude_client.replay (BROAD's; a recording whose truth has its own frames, `align = "both"`, aligned on its own
first). Any recording attitude_client.replay reads: BROAD-layout HDF5 or a CSV trial (docs/recordings.md).

Data: BROAD (D. Laidig, M. Caruso, A. Cereatti, T. Seel, Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import argparse
import json
import sys
from importlib import metadata
from pathlib import Path

from attitude_client.replay import ATTRIBUTION, broad_scores, load_trial, run_vqf  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trials", nargs="+", type=Path)
    ap.add_argument("--out", required=True, type=Path)
    args = ap.parse_args()
    out = {"vqf_version": metadata.version("vqf"), "attribution": ATTRIBUTION}
    for p in args.trials:
        trial = load_trial(p, None)
        s = broad_scores(run_vqf(trial), None, trial["opt_quat"], trial["movement"], trial["truth"])
        out[trial["name"]] = {k: s[k] for k in ("total_rmse_deg", "heading_rmse_deg", "inclination_rmse_deg")}
    args.out.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
