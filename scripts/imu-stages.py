#!/usr/bin/env python3
"""Instructions per IMU sample by stage: one recorded trial through one vehicle of the service, under
callgrind (instruction counts do not depend on the machine's load, so two builds compare on a shared
machine).

    scripts/imu-stages.py TRIAL [--example target/release/examples/imu_profile] [--config config/imu.json5]
                          [--other OTHER_EXAMPLE] [--json] [--keep CALLGRIND_FILE]

TRIAL is a trial file of `scripts/broad-export.py` (e.g. BROAD 07 exported). The example is built with
`cargo build --release -p attitude-lab --example imu_profile`; `--other` runs a second build of it (a build
of main, say) and prints both columns. What is counted is `imu_bench::bench_trial` (the loop `imu-bench`
times: every sample as a `P/V/imu` input through `VehicleState`, an estimate per sample), one run, by
stage (inclusive counts of the functions named, per sample):

* vehicle: arrival checks, reorder window, history (`VehicleState::on_measurement` less the two below)
* estimate: the estimate built, checked and handed out per sample (`VehicleState::check_and_emit`)
* pipeline, of which: gyro propagation (`AttitudeFilter::gyro_interval_with`: the filter's propagation,
  its Φ and process noise, the gyro bookkeeping), updates (tilt, heading, bias, floors),
  field channel (`FieldChannel::update_by` and `observation`), preprocessing (gyro frame, rest detector,
  gravity low-pass), the step's own work (the rest of `Ahrs::step`)
* imu-bench: what the benchmark does with each estimate (`bench_trial` less `on_measurement`)
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

STAGES = {
    "total": [r"imu_bench::bench_trial( \[|\s*$)"],
    "on_measurement": [r"VehicleState::on_measurement( \[|\s*$)"],
    "estimate": [r"VehicleState::check_and_emit( \[|\s*$)"],
    "pipeline": [r"ahrs::Ahrs::step( \[|\s*$)"],
    "gyro propagation": [r"AttitudeFilter>::gyro_interval_with( \[|\s*$)"],
    "updates": [
        r"AttitudeFilter>::observe( \[|\s*$)",
        r"AttitudeFilter>::observe_bias( \[|\s*$)",
        r"AttitudeFilter>::inflate_attitude( \[|\s*$)",
    ],
    "field channel": [r"FieldChannel::update_by( \[|\s*$)", r"FieldChannel::observation( \[|\s*$)"],
    "preprocessing": [r"ahrs::Ahrs::preprocess( \[|\s*$)"],
}


def counts(example: str, trial: str, config: str, keep: str | None) -> tuple[dict[str, float], int]:
    with tempfile.TemporaryDirectory() as d:
        out = keep or os.path.join(d, "cg.out")
        run = subprocess.run(
            ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", example, trial, "1", config],
            capture_output=True,
            text=True,
            check=True,
        )
        m = re.search(r"(\d+) samples", run.stdout)
        if not m:
            sys.exit(f"no sample count in the example's output: {run.stdout!r}")
        n = int(m.group(1))
        ann = subprocess.run(
            ["callgrind_annotate", "--inclusive=yes", "--threshold=100", out],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    lines = [l for l in ann.splitlines() if re.match(r"\s*[\d,]+ \(", l) and "=>" not in l]
    got = {}
    for stage, patterns in STAGES.items():
        total = 0
        for p in patterns:
            # (callgrind_annotate lists a function once per file its code came from; the largest
            # inclusive count is the function's.)
            hits = [int(l.split()[0].replace(",", "")) for l in lines if re.search(p, l)]
            if not hits:
                # (A function renamed or inlined away: a stage counted as 0 would mislead.)
                sys.exit(f"{example}: no function matches {p!r} in the profile; update STAGES")
            total += max(hits)
        got[stage] = total / n
    return got, n


def table(c: dict[str, float]) -> list[tuple[str, float]]:
    vehicle = c["on_measurement"] - c["pipeline"] - c["estimate"]
    own = c["pipeline"] - c["gyro propagation"] - c["updates"] - c["field channel"] - c["preprocessing"]
    return [
        ("vehicle (arrival, reorder window, history)", vehicle),
        ("estimate per sample (built, checked, handed out)", c["estimate"]),
        ("pipeline: gyro propagation (filter, Φ, noise, bookkeeping)", c["gyro propagation"]),
        ("pipeline: updates (tilt, heading, bias, floors)", c["updates"]),
        ("pipeline: field channel", c["field channel"]),
        ("pipeline: preprocessing (gyro frame, rest, gravity low-pass)", c["preprocessing"]),
        ("pipeline: the step's own work", own),
        ("imu-bench's bookkeeping", c["total"] - c["on_measurement"]),
        ("total", c["total"]),
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("trial")
    ap.add_argument("--example", default="target/release/examples/imu_profile")
    ap.add_argument("--other")
    ap.add_argument("--config", default="config/imu.json5")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--keep", help="keep the callgrind output of this build in this file")
    a = ap.parse_args()
    runs = {"this": counts(a.example, a.trial, a.config, a.keep)}
    if a.other:
        runs["other"] = counts(a.other, a.trial, a.config, None)
    rows = {k: table(c) for k, (c, _) in runs.items()}
    if a.json:
        print(json.dumps({k: dict(v) for k, v in rows.items()} | {"samples": runs["this"][1]}))
        return
    print(f"instructions per sample, {runs['this'][1]} samples of {os.path.basename(a.trial)}")
    head = "| stage | " + " | ".join(runs) + " |"
    print(head)
    print("|---|" + "--:|" * len(runs))
    for i, (name, _) in enumerate(rows["this"]):
        print(f"| {name} | " + " | ".join(f"{rows[k][i][1]:,.0f}" for k in runs) + " |")


if __name__ == "__main__":
    main()
