#!/usr/bin/env bash
# Runs every test of attitude-service on a fresh machine: formatting, the Rust unit, property and
# integration tests (which run the real binary), with release optimisation (statistical tests are
# Monte-Carlo runs). Installs nothing outside the project directory.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --all -- --check

echo "== cargo test (optimised test profile)"
cargo test --all-targets --locked
