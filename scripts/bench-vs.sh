#!/usr/bin/env bash
# The particle filter's step cost of two builds, measured alternately on this machine (a busy machine
# slows both alike): `attitude-lab bench --json` of OLD and NEW, ROUNDS rounds each, and the median
# of the per-round ratios NEW/OLD of `qpf_ns_per_particle_step` (and of each build's ratio to its own
# MEKF, which cancels the machine's load once more).
#   scripts/bench-vs.sh OLD_BINARY NEW_BINARY [ROUNDS=7] [extra bench options, e.g. --particles 4000]
# A baseline binary: `git worktree add /tmp/base main && cargo build --release -p attitude-lab` there (or
# any older build's target/release/attitude-lab; builds before the lab had its own binary:
# target/release/attitude-service, which then had `bench`).
set -euo pipefail
old=$1; new=$2; rounds=${3:-7}; shift $(( $# < 3 ? $# : 3 ))
out=$(mktemp -d)
for r in $(seq 1 "$rounds"); do
  "$old" bench --json "$@" > "$out/old-$r.json"
  "$new" bench --json "$@" > "$out/new-$r.json"
done
python3 - "$out" "$rounds" <<'PY'
import json, statistics, sys
out, rounds = sys.argv[1], int(sys.argv[2])
load = lambda k, r: json.load(open(f"{out}/{k}-{r}.json"))
o = [load("old", r) for r in range(1, rounds + 1)]
n = [load("new", r) for r in range(1, rounds + 1)]
med = statistics.median
key = "qpf_ns_per_particle_step"
print(f"particles {n[0]['particles']}, new build: {n[0].get('isa', '?')}, {n[0].get('qpf_threads', 1)} thread(s); {rounds} rounds")
print(f"qpf:average ns per particle-step: old median {med(x[key] for x in o):.1f} (min {min(x[key] for x in o):.1f}), "
      f"new median {med(x[key] for x in n):.1f} (min {min(x[key] for x in n):.1f})")
print(f"new/old, median of per-round ratios: {med(b[key] / a[key] for a, b in zip(o, n)):.3f}")
print(f"qpf/mekf of each build, medians: old {med(x['qpf_over_mekf'] for x in o):.1f}, new {med(x['qpf_over_mekf'] for x in n):.1f}")
PY
rm -r "$out"
