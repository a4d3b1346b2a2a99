#!/usr/bin/env python3
"""The engine's instructions per estimate by stage, from two callgrind runs of `examples/engine_cost.rs`
with different tick counts (their difference cancels the start-up and the first vehicles' creation):

    cargo build --release --example engine_cost
    valgrind --tool=callgrind --callgrind-out-file=A target/release/examples/engine_cost 1000 20
    valgrind --tool=callgrind --callgrind-out-file=B target/release/examples/engine_cost 1000 60
    scripts/engine-stages.py A B 40000          # the estimates B has more than A

Stages are inclusive counts of the functions that make them (callgrind_annotate --inclusive=yes); a
stage's functions do not overlap, so the stages add up to the engine's threads minus what is listed
as the rest (channels, scheduling, the worker's own loop).
"""
import os
import re
import subprocess
import sys

STAGES = [
    ("engine threads, all", r"pthread_create\.c:start_thread"),
    ("dispatcher: decoding the inputs (JSON into samples)", r"wire::input::decode_batch_(into|via) \["),
    ("dispatcher: the rest (classify, own, queue, schedule)", None),
    ("vehicle: arrival checks, reorder window, history, filter, gate", r"VehicleState::on_measurement \["),
    ("  of which the filter (propagation and update)", r"Driver<F> as attitude_core::filters::AttitudeFilter>::process \["),
    ("estimate: Published into EstimateMsg", r"EstimateMsg as core::convert::From<attitude_core::vehicle::published::Published>>::from \["),
    ("estimate: serialised", r"(wire::estimate_json::write_estimate|Serialize for attitude_service::wire::estimate::EstimateMsg>::serialize) \["),
    ("estimate: the rest of publish_estimate (snapshot, counts)", None),
]


def inclusive(path):
    out = subprocess.run(
        ["callgrind_annotate", "--inclusive=yes", "--auto=no", "--threshold=100", path],
        capture_output=True, text=True, cwd="/",
    ).stdout
    rows = []
    for line in out.splitlines():
        m = re.match(r"^\s*([0-9,]+) \(\s*[0-9.]+%\)\s+(.*)$", line)
        if m and not m.group(2).startswith("=>"):
            rows.append((int(m.group(1).replace(",", "")), m.group(2)))
    return rows


def largest(rows, pattern):
    # (A function inlining code of other files is listed once per file, each time with its whole
    # inclusive count or a part of it: the largest is the function's.)
    return max((v for v, name in rows if re.search(pattern, name)), default=0)


def main():
    a, b, n = (os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2]), float(sys.argv[3]))
    ra, rb = inclusive(a), inclusive(b)
    per = lambda p: (largest(rb, p) - largest(ra, p)) / n
    figures = {}
    for name, pattern in STAGES:
        if pattern:
            figures[name] = per(pattern)
    figures["dispatcher: the rest (classify, own, queue, schedule)"] = per(
        r"Engine>::dispatcher \[") - figures["dispatcher: decoding the inputs (JSON into samples)"]
    figures["estimate: the rest of publish_estimate (snapshot, counts)"] = per(
        r"Engine::publish_estimate \[") - figures["estimate: serialised"]
    for name, _ in STAGES:
        print(f"{figures[name]:9.0f}  {name}")


if __name__ == "__main__":
    main()
