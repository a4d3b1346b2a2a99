#!/usr/bin/env bash
# Black-box tests of the attitude service from Python (tests/python), against the real release binary.
#
#   bash scripts/python-tests.sh [pytest args...]
#
# Creates .venv at the repository root when missing, installs the pinned Python packages into it
# (from PyPI; ROS 2 Kilted's rclpy with Fast DDS among them), builds the release binary (with the
# `dds` feature, which tests/python/test_ros2_dds.py needs) only when it is missing, and runs pytest with the venv's
# Python. Exits with pytest's exit code. Needs only python3 (with venv) on a fresh machine, plus cargo
# when the binary has to be built.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

VENV="$ROOT/.venv"
PY="$VENV/bin/python"

# Versions installed and tested together.
PACKAGES=(
  "eclipse-zenoh==1.10.2"
  "pytest==9.2.0"
  "numpy==2.4.6"
  "jsonschema==4.26.0"
  "scipy==1.17.1"
  "vqf==2.1.2"
  "h5py==3.16.0"
  "ahrs==0.3.1"
  "foxglove-sdk==0.30.3"
  # attitude-view --rerun (tests/python/test_view_rerun.py): its gRPC server, web viewer and chunk reader
  "rerun-sdk==0.41.0"
  "websockets==17.4"
  "protobuf==7.36.2"
  # The independent sparse-grid rules of tests/python/test_sghq_rule.py (numpoly is its polynomial
  # library, a source package that builds in seconds).
  "chaospy==4.3.21"
  "numpoly==1.3.9"
  "prometheus-client==0.26.0"
  # The ROS 2 edge's tests (tests/python/test_ros2.py): rosbags for CDR, the RIHS01 type hashes and the bags,
  # xxhash for rmw_zenoh's GIDs (XXH3-128).
  "rosbags==0.11.9"
  "xxhash==3.6.0"
  # A second independent ROS 2-over-Zenoh client (tests/python/test_ros2_sdk.py) and its dependencies.
  "zenoh-ros2-sdk==0.1.8"
  "GitPython==3.2.1"
  "json5==0.17.3"
  "tqdm==4.70.1"
  # Real ROS 2 (Kilted: rclpy on Fast DDS) for the service on DDS (tests/python/test_ros2_dds.py).
  "ros-kilted-rclpy==9.1.2"
  "ros-kilted-rmw-fastrtps-cpp==9.3.3"
  "ros-kilted-sensor-msgs==5.5.1"
  "ros-kilted-diagnostic-msgs==5.5.1"
  "ros-kilted-std-srvs==5.5.1"
)

if [[ ! -x "$PY" ]]; then
  echo "python-tests: creating $VENV" >&2
  python3 -m venv "$VENV"
fi

# Install only when something is missing or at another version (pip is slow even when satisfied).
if ! "$PY" - "${PACKAGES[@]}" <<'PYEOF'
import sys
from importlib import metadata
for spec in sys.argv[1:]:
    name, version = spec.split("==")
    try:
        if metadata.version(name) != version:
            sys.exit(1)
    except metadata.PackageNotFoundError:
        sys.exit(1)
PYEOF
then
  echo "python-tests: installing ${PACKAGES[*]}" >&2
  "$PY" -m pip install -q --disable-pip-version-check "${PACKAGES[@]}"
fi

# The Python client package (clients/python), installed editable from this tree: the tests import it as a
# user does. Reinstalled when the venv's copy points elsewhere (a venv copied from another checkout) or lacks a
# console script.
if ! "$PY" - "$ROOT/clients/python/src" <<'PYEOF'
import pathlib, sys
try:
    import attitude_client
except ImportError:
    sys.exit(1)
from importlib import metadata
if not pathlib.Path(attitude_client.__file__).resolve().is_relative_to(pathlib.Path(sys.argv[1]).resolve()):
    sys.exit(1)
# Every console script of pyproject.toml is installed (a venv from before a script was added lacks it).
scripts = {e.name for e in metadata.distribution("attitude-client").entry_points if e.group == "console_scripts"}
sys.exit(0 if {"attitude-replay", "attitude-view", "attitude-bag-replay"} <= scripts else 1)
PYEOF
then
  echo "python-tests: installing clients/python (editable)" >&2
  "$PY" -m pip install -q --disable-pip-version-check --no-deps -e "$ROOT/clients/python"
fi

# The service binary, and the lab's (attitude-lab: imu-study, imu-bench, bench, quadrature), both built by
# one workspace build.
BIN="$ROOT/target/release/attitude-service"
LAB="$ROOT/target/release/attitude-lab"
if [[ ! -x "$BIN" || ! -x "$LAB" ]]; then
  echo "python-tests: $BIN or $LAB is missing; building both (with the DDS plugin: --features dds)" >&2
  bash "$ROOT/scripts/install-build-deps.sh"
  cargo build --release --locked --workspace --features attitude-service/dds
fi

# The zenoh router of the fleet tests (tests/python/test_fleet.py), built once into a cache.
bash "$ROOT/scripts/ensure-zenohd.sh" >/dev/null

set +e
ATTITUDE_SERVICE_BIN="$BIN" ATTITUDE_LAB_BIN="$LAB" "$PY" -m pytest -q tests/python "$@"
code=$?
set -e
exit "$code"
