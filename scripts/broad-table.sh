#!/usr/bin/env bash
# Replays the four BROAD trials of ../shared/data/broad through the real service (config/imu.json5) with
# clients/python/broad_replay.py and prints the markdown table of docs/broad.md.
#
#   scripts/broad-table.sh [DATA_DIR] [OUT_DIR]      (defaults ../shared/data/broad, target/broad)
#
# Starts `attitude-service serve --config config/imu.json5` on a free port, replays each trial (MEKF and
# qpf:average with 500 particles, one vehicle after the other), stops the service, and writes per trial
# OUT_DIR/TRIAL.json (the --json line) and OUT_DIR/TRIAL.details.json.
set -euo pipefail
cd "$(dirname "$0")/.."
DATA=${1:-../shared/data/broad}
OUT=${2:-target/broad}
PY=${PYTHON:-.venv/bin/python}
BIN=${ATTITUDE_SERVICE_BIN:-target/release/attitude-service}
mkdir -p "$OUT"
PORT=$("$PY" -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
"$BIN" serve --config config/imu.json5 --listen "tcp/127.0.0.1:$PORT" >"$OUT/service.log" 2>&1 &
SERVICE=$!
trap 'kill $SERVICE 2>/dev/null || true' EXIT
TRIALS=(02_undisturbed_slow_rotation_B 07_undisturbed_fast_rotation_B 16_undisturbed_fast_translation_B 25_disturbed_tapping_B)
for t in "${TRIALS[@]}"; do
  "$PY" clients/python/broad_replay.py "$DATA/$t.hdf5" --connect "tcp/127.0.0.1:$PORT" --particles 500 --tag "table${t%%_*}" --json \
    --details "$OUT/$t.details.json" >"$OUT/$t.json"
done
kill $SERVICE
wait $SERVICE 2>/dev/null || true
trap - EXIT
"$PY" - "$DATA" "$OUT" "${TRIALS[@]}" <<'PYEOF'
import json, sys
from pathlib import Path
data, out, trials = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3:]
pub = {k: json.loads((data / f"published_{k}_rmse.json").read_text())["trials"] for k in ("madgwick", "mahony")}
cols = [("mekf", "MEKF (service)"), ("qpf:average", "qpf:average (service, 500 particles)"), ("vqf", "VQF 2.1.2"),
        ("madgwick", "Madgwick (ahrs 0.3.1, β = 0.12)")]
print("| trial | estimator | total ° | heading ° | inclination ° | total / VQF |")
print("|---|---|---:|---:|---:|---:|")
for t in trials:
    r = json.loads((out / f"{t}.json").read_text().strip().splitlines()[-1])
    rows = [(label, r[key]) for key, label in cols]
    rows += [(f"published {k.capitalize()} (TAGP)", pub[k][t]["tagp_parameters"]) for k in ("madgwick", "mahony")]
    vqf = r["vqf"]["total_rmse_deg"]
    for label, m in rows:
        print(f"| {t} | {label} | {m['total_rmse_deg']:.2f} | {m['heading_rmse_deg']:.2f} | "
              f"{m['inclination_rmse_deg']:.2f} | {m['total_rmse_deg'] / vqf:.2f} |")
PYEOF
