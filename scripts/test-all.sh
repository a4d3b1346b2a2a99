#!/usr/bin/env bash
# Runs every test of attitude-service on a fresh machine (what .ci/run calls):
#   1. formatting;
#   2. the Rust unit, property, integration and loopback-zenoh tests, and the benchmarks in test mode,
#      all in the release profile (statistical tests are Monte-Carlo runs; one build serves all, the
#      release binary included);
#   3. the black-box Python suite (eclipse-zenoh 1.10.2 in .venv, created and filled from PyPI) against
#      the release binaries (attitude-service, and attitude-lab for the studies and benches);
#   4. the API documentation built with warnings denied (every intra-doc link resolves).
# Needs a Rust toolchain, a C toolchain and python3 (cmake and libclang for the `dds` feature come from
# scripts/install-build-deps.sh). Installs Python packages into .venv in the project, and the zenoh
# router zenohd 1.10.2 once into ~/.cache/attitude-service (scripts/ensure-zenohd.sh; ZENOHD_CACHE moves it).
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --all -- --check

# The `dds` feature (the ROS 2 edge on DDS, zenoh-plugin-ros2dds) builds CycloneDDS from C: cmake and
# libclang, installed by apt-get when missing. Everything is built once, with the feature, by `cargo
# test`: it builds the workspace's release binaries for the integration tests too
# (target/release/attitude-service and target/release/attitude-lab, which the Python suite runs), so a
# separate `cargo build`, whose dependencies' features differ from the tests' (dev-dependencies unify
# theirs), would only compile zenoh a second time.
echo "== build dependencies of the dds feature"
bash scripts/install-build-deps.sh

echo "== cargo test --release --workspace --features dds (builds both binaries as well)"
cargo test --release --workspace --all-targets --locked --features attitude-service/dds
test -x target/release/attitude-service
test -x target/release/attitude-lab

echo "== python black-box tests"
bash scripts/python-tests.sh

echo "== cargo doc, warnings denied"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --locked --workspace --features attitude-service/dds
