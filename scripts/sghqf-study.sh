#!/usr/bin/env bash
# The SGHQF part of docs/accuracy.md: sghqf:propagated and sghqf:average at levels 2 and 3 on the three
# standard scenarios beside USQUE (measured in the same runs, for the cost ratio), the paired fiducial
# comparison (one magnetometer from a uniformly random attitude, 200 runs, two seeds) and the
# large-initial-error comparison with USQUE (star-tracker from Gaussian errors of 30°, 60° and 90° per
# axis), and where level 3 refuses inputs, the same runs with them skipped. Writes
# docs/accuracy/sghqf-*/{summary.json,summary.md,*.png}. About 15 minutes on 2 cores.
#   RUNS=100 PAIRED_RUNS=200 SEED=1 ./scripts/sghqf-study.sh
# One worker (--jobs 1) so that the µs/step of the filters of one run are measured alike.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${RUNS:-100}
SEED=${SEED:-1}
PAIRED_RUNS=${PAIRED_RUNS:-200}
FILTERS=usque:propagated,usque:average,sghqf:propagated,sghqf:average
cargo build --release --locked -p attitude-lab
bin=./target/release/attitude-lab
out=docs/accuracy
mkdir -p "$out"
for scenario in star-tracker magnetometer-leo lost-in-space; do
  for level in 2 3; do
    "$bin" montecarlo --scenario "$scenario" --filters "$FILTERS" --level "$level" --runs "$RUNS" \
      --seed "$SEED" --jobs 1 --out "$out/sghqf-$scenario-L$level" > /dev/null
  done
done
for level in 2 3; do
  for seed in 1 2; do
    "$bin" montecarlo --scenario magnetometer-leo --uniform-init --filters sghqf:propagated,sghqf:average \
      --level "$level" --runs "$PAIRED_RUNS" --seed "$seed" --jobs 1 \
      --out "$out/sghqf-paired-L$level-seed$seed" > /dev/null
  done
done
for deg in 30 60 90; do
  for level in 2 3; do
    "$bin" montecarlo --scenario star-tracker --init-error-deg "$deg" --duration 1800 \
      --filters "$FILTERS" --level "$level" --runs "$RUNS" --seed "$SEED" --jobs 1 \
      --out "$out/sghqf-large-$deg-L$level" > /dev/null
  done
done
# Where level 3 refuses a step (negative weights from a prior of 90° or more): the same runs with the
# refused inputs skipped, as the service's vehicle rolls them back.
skipped() {
  "$bin" montecarlo --skip-refused --filters "$FILTERS" --level 3 --seed "$SEED" --jobs 1 "$@" > /dev/null
}
skipped --scenario lost-in-space --runs "$RUNS" --out "$out/sghqf-skip-lost-in-space-L3"
skipped --scenario star-tracker --init-error-deg 90 --duration 1800 --runs "$RUNS" \
  --out "$out/sghqf-skip-large-90-L3"
for seed in 1 2; do
  "$bin" montecarlo --skip-refused --scenario magnetometer-leo --uniform-init \
    --filters sghqf:propagated,sghqf:average --level 3 --runs "$PAIRED_RUNS" --seed "$seed" --jobs 1 \
    --out "$out/sghqf-skip-paired-L3-seed$seed" > /dev/null
done
echo "study written under $out/sghqf-*"
