#!/usr/bin/env bash
# Replays every BROAD trial of a directory through the real service (config/imu.json5) on P/V/imu with
# attitude-replay (clients/python) and prints the markdown table of docs/broad.md: per trial the MEKF and
# qpf:average through the service (accuracy and honesty), VQF and Madgwick on the same samples, the
# benchmark's published Madgwick, and the leave-one-out (held-out) total of the tuning record.
#
#   scripts/broad-table.sh [DATA_DIR] [OUT_DIR] [TUNING_JSON]
#       defaults: ../shared/data/broad, target/broad, docs/broad/tuning.json
#
# Starts `attitude-service serve --config config/imu.json5` on a free port, replays each trial (one vehicle
# per filter, one after the other; the QPF with the preset's particles), stops the service, and writes per trial
# OUT_DIR/TRIAL.json (the --json line) and OUT_DIR/TRIAL.details.json. The tuning record is what
# `attitude-lab imu-study TRIALS --tune config/imu-tuning.json5 --loo --out FILE` writes.
set -euo pipefail
cd "$(dirname "$0")/.."
DATA=${1:-../shared/data/broad}
OUT=${2:-target/broad}
TUNING=${3:-docs/broad/tuning.json}
PY=${PYTHON:-.venv/bin/python}
BIN=${ATTITUDE_SERVICE_BIN:-target/release/attitude-service}
[[ -d "$DATA" ]] || { echo "broad-table: no data directory $DATA" >&2; exit 1; }
[[ -f "$TUNING" ]] || { echo "broad-table: no tuning record $TUNING" >&2; exit 1; }
mkdir -p "$OUT"
PORT=$("$PY" -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
"$BIN" serve --config config/imu.json5 --listen "tcp/127.0.0.1:$PORT" >"$OUT/service.log" 2>&1 &
SERVICE=$!
trap 'kill $SERVICE 2>/dev/null || true' EXIT
TRIALS=()
for f in "$DATA"/*.hdf5; do
  t=$(basename "$f" .hdf5)
  TRIALS+=("$t")
  "$PY" -m attitude_client.replay "$f" --connect "tcp/127.0.0.1:$PORT" --tag "table${t%%_*}" \
    --json --details "$OUT/$t.details.json" >"$OUT/$t.json"
done
kill $SERVICE
wait $SERVICE 2>/dev/null || true
trap - EXIT
"$PY" - "$DATA" "$OUT" "$TUNING" "${TRIALS[@]}" <<'PYEOF'
import json, math, sys
from pathlib import Path
data, out, tuning, trials = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3]), sys.argv[4:]
pub = json.loads((data / "published_madgwick_rmse.json").read_text())["trials"]
record = json.loads(tuning.read_text())
# Held out: a trial's own fold (--loo), else its set's (--loo-sets: tuned on the other sets).
folds = {f["trial"]: f for f in record.get("folds", [])}
for sf in record.get("set_folds", []):
    for f in sf["trials"]:
        folds.setdefault(f["trial"], f)
print("| trial | filter | total ° | heading ° | incl. ° | held-out total ° | tilt in 99% | tilt NEES med. | "
      "heading in 99% | heading offset ° | VQF total / heading / incl. ° | Madgwick (ahrs) total ° | "
      "published Madgwick total ° |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
ratios = {"mekf": [], "qpf:average": []}
incl = {"mekf": [], "qpf:average": []}
for t in trials:
    r = json.loads((out / f"{t}.json").read_text().strip().splitlines()[-1])
    v, m = r["vqf"], r["madgwick"]
    held = folds.get(t, {}).get("held_out", {}).get("total_rmse_deg")
    for spec in ("mekf", "qpf:average"):
        s = r[spec]
        ratios[spec].append(s["total_rmse_deg"] / v["total_rmse_deg"])
        incl[spec].append(s["inclination_rmse_deg"] / v["inclination_rmse_deg"])
        h = f"{held:.2f}" if spec == "mekf" and held is not None else "–"
        print(f"| {t} | {spec} | {s['total_rmse_deg']:.2f} | {s['heading_rmse_deg']:.2f} | "
              f"{s['inclination_rmse_deg']:.2f} | {h} | {s['tilt_in99']:.3f} | {s['tilt_nees_median']:.2f} | "
              f"{s['heading_in99']:.3f} | {s['heading_offset_deg']:+.2f} | "
              f"{v['total_rmse_deg']:.2f} / {v['heading_rmse_deg']:.2f} / {v['inclination_rmse_deg']:.2f} | "
              f"{m['total_rmse_deg']:.2f} | {pub[t]['tagp_parameters']['total_rmse_deg']:.2f} |")
print()
for spec in ratios:
    g = math.exp(sum(map(math.log, ratios[spec])) / len(ratios[spec]))
    gi = math.exp(sum(map(math.log, incl[spec])) / len(incl[spec]))
    print(f"{spec}: geometric mean of total / VQF {g:.3f}, of inclination / VQF {gi:.3f}; total ≤ VQF on "
          f"{sum(x <= 1 for x in ratios[spec])} of {len(ratios[spec])} trials, inclination ≤ VQF on "
          f"{sum(x <= 1 for x in incl[spec])}, worst total ratio {max(ratios[spec]):.2f}")
PYEOF
