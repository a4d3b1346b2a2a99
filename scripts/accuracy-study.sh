#!/usr/bin/env bash
# Regenerates the accuracy study of docs/accuracy.md: every filter on every standard scenario, the
# fiducial comparison where it matters (few particles, diffuse clouds), and the particle-count sweep.
# Writes docs/accuracy/<name>/{summary.json,summary.md,*.png}. About 1.5 minutes on 2 cores.
#   RUNS=100 SWEEP_RUNS=100 PAIRED_RUNS=200 ./scripts/accuracy-study.sh
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${RUNS:-100}
SWEEP_RUNS=${SWEEP_RUNS:-100}
SEED=${SEED:-1}
PAIRED_RUNS=${PAIRED_RUNS:-200}
ALL=mekf,usque:propagated,usque:average,qpf:propagated,qpf:average
cargo build --release --locked -p attitude-lab
bin=./target/release/attitude-lab
out=docs/accuracy
mkdir -p "$out"
for scenario in star-tracker magnetometer-leo lost-in-space; do
  "$bin" montecarlo --scenario "$scenario" --filters "$ALL" --runs "$RUNS" --seed "$SEED" --out "$out/$scenario" > /dev/null
done
# Where the fiducial could matter: a single magnetometer from a uniformly random attitude (ring-shaped,
# diffuse posteriors) with few particles. Paired (common random numbers), 200 runs, two seeds.
for n in 250 500 1000; do
  for seed in 1 2; do
    "$bin" montecarlo --scenario magnetometer-leo --uniform-init --particles "$n" \
      --filters qpf:propagated,qpf:average --runs "$PAIRED_RUNS" --seed "$seed" --out "$out/paired-$n-seed$seed" > /dev/null
  done
done
for filter in qpf:average qpf:propagated; do
  "$bin" sweep --scenario magnetometer-leo --uniform-init --filter "$filter" --particles 250,500,1000,2000,5000 \
    --runs "$SWEEP_RUNS" --seed "$SEED" --out "$out/sweep-${filter/:/-}" > /dev/null
done
echo "study written under $out/"
