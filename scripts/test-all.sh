#!/usr/bin/env bash
# Runs every test of attitude-service on a fresh machine (what .ci/run calls):
#   1. formatting;
#   2. the Rust unit, property, integration and loopback-zenoh tests, and the benchmarks in test mode,
#      all in the release profile (statistical tests are Monte-Carlo runs; one build serves all);
#   3. the black-box Python suite (eclipse-zenoh 1.10.2 in .venv, created and filled from PyPI) against
#      the release binary.
# Needs a Rust toolchain, a C toolchain and python3 (cmake and libclang for the `dds` feature come from
# scripts/install-build-deps.sh). Installs Python packages into .venv in the project, and the zenoh
# router zenohd 1.10.2 once into ~/.cache/attitude-service (scripts/ensure-zenohd.sh; ZENOHD_CACHE moves it).
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --all -- --check

# The `dds` feature (the ROS 2 edge on DDS, zenoh-plugin-ros2dds) builds CycloneDDS from C: cmake and
# libclang, installed by apt-get when missing. Everything below is built once, with the feature.
echo "== build dependencies of the dds feature"
bash scripts/install-build-deps.sh

echo "== cargo build --release --features dds"
cargo build --release --locked --features dds

echo "== cargo test --release --workspace --features dds"
cargo test --release --workspace --all-targets --locked --features attitude-service/dds

echo "== python black-box tests"
bash scripts/python-tests.sh
