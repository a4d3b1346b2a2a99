#!/usr/bin/env bash
# The service under `loadgen` against `loadgen --echo`, alternating in one session, so that every figure
# has its baseline measured in the same minutes of this shared machine (issue 15, deliver 3).
#
#   scripts/load-vs-echo.sh [-r ROUNDS] [-d SECONDS] [-b BINARY] [-o OTHER_BINARY] [-l LAB_BINARY] [CASE ...]
#   (run it under `nice -n -19` to keep other jobs of a shared machine from deciding the figures)
#
# Cases (default: qpf mekf imu imu-capped):
#   qpf   1000 vehicles × 10 Hz, a vector set (three stars) and a gyro sample each per tick,
#         qpf:average with 1000 particles;                      target p99 ≤ 3× the echo's, nothing lost
#   mekf  the same load with the MEKF;                          target p99 ≤ 2× the echo's, nothing lost
#   qpf-spread, mekf-spread  the same loads with each vehicle at its own phase of the 100 ms
#         (`loadgen --spread`, as independent vehicles send) instead of one burst per tick
#   imu   10 vehicles replaying raw IMU samples at once, 100 samples per put, 100 puts/s each:
#         100 000 samples/s, config/imu.json5 (the MEKF), an estimate per sample; target ≥ 100 000/s
#   imu-capped  the same with service.imu.max_estimate_rate_hz = 100 (an estimate per vehicle every
#         10 ms of samples; `loadgen --capped`: an estimate answers the samples up to its time)
# Each round runs, per case, the echo, then the service of BINARY (default target/release), then (with
# -o) the service of OTHER_BINARY (e.g. a build of main), each on a fresh service process; the load
# (`loadgen`) and `bench` are LAB_BINARY's (default target/release/attitude-lab). It prints
# one line per run (estimates/s, lost, rejected, p50, p99, max, the service's CPU seconds per 1000
# estimates and its peak RSS) and, per case, the median over the rounds of each run's p99 over the
# echo's p99 of the same round. Under each service run a `#` line gives each thread's share of the service's
# CPU over the load (/proc/PID/task/*/stat, the threads named alike summed: the workers are one line). Each round starts with the machine's state: the load average and
# `bench`'s particle-filter step (1000 particles) in those minutes (17.8 µs on a quiet machine).
# The raw JSON of every run stays in the output folder it names.
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=1; dur=20; bin=target/release/attitude-service; other=""; lab=target/release/attitude-lab
while getopts "r:d:b:o:l:" opt; do
  case $opt in
    r) rounds=$OPTARG ;; d) dur=$OPTARG ;; b) bin=$OPTARG ;; o) other=$OPTARG ;; l) lab=$OPTARG ;;
    *) sed -n 4,19p "$0"; exit 2 ;;
  esac
done
shift $((OPTIND - 1))
cases=("${@:-qpf mekf imu imu-capped}")
read -r -a cases <<< "${cases[*]}"
out=$(mktemp -d /tmp/load-vs-echo.XXXXXX)
conf=$out/conf; mkdir -p "$conf"
echo '{ service: { filter: { kind: "qpf", fiducial: "average", particles: 1000 } } }' > "$conf/qpf.json5"
echo '{ service: { filter: { kind: "mekf" } } }' > "$conf/mekf.json5"
cp "$conf/qpf.json5" "$conf/qpf-spread.json5"; cp "$conf/mekf.json5" "$conf/mekf-spread.json5"
cp config/imu.json5 "$conf/imu.json5"
sed 's/max_estimate_rate_hz: 0,/max_estimate_rate_hz: 100,/' config/imu.json5 > "$conf/imu-capped.json5"
grep -q 'max_estimate_rate_hz: 100,' "$conf/imu-capped.json5"
port=$((20000 + RANDOM % 20000))

load_args() { # the loadgen options of a case
  case $1 in
    qpf|mekf) echo "--vehicles 1000 --rate 10 --duration $dur" ;;
    qpf-spread|mekf-spread) echo "--vehicles 1000 --rate 10 --duration $dur --spread" ;;
    imu) echo "--vehicles 10 --imu 100 --rate 100 --duration $dur" ;;
    imu-capped) echo "--vehicles 10 --imu 100 --rate 100 --duration $dur --capped" ;;
  esac
}

# thread_ticks PID: the process's CPU ticks by thread name ("name=ticks ..."), digits and '-' at the end of
# a name dropped so that a pool's threads are one entry.
thread_ticks() {
  python3 - "$1" <<'PY'
import collections, os, sys
pid, per = sys.argv[1], collections.Counter()
for t in os.listdir(f"/proc/{pid}/task"):
    try:
        s = open(f"/proc/{pid}/task/{t}/stat").read()
    except OSError:
        continue  # (a thread that ended between the listing and the read)
    f = s[s.rindex(")") + 2:].split()
    per[s[s.index("(") + 1:s.rindex(")")].rstrip("0123456789-")] += int(f[11]) + int(f[12])
print(" ".join(f"{k}={v}" for k, v in per.items()))
PY
}

# thread_shares BEFORE AFTER: each thread name's share of the ticks between two thread_ticks.
thread_shares() {
  python3 - "$1" "$2" <<'PY'
import sys
parse = lambda a: {k: int(v) for k, v in (x.rsplit("=", 1) for x in a.split())}
b, a = parse(sys.argv[1]), parse(sys.argv[2])
d = {k: v - b.get(k, 0) for k, v in a.items()}
total = sum(d.values()) or 1
print(", ".join(f"{k} {100 * v / total:.1f}%" for k, v in sorted(d.items(), key=lambda kv: -kv[1]) if v > 0))
PY
}

# run CASE LABEL [BINARY]: the echo when BINARY is empty, else that binary's service.
run() {
  local case=$1 label=$2 b=${3:-} json=$out/$1-$2-$4.json
  # shellcheck disable=SC2046
  if [[ -z $b ]]; then
    $lab loadgen $(load_args "$case") --echo --json > "$json"
    echo '{}' > "$json.service"
  else
    port=$((port + 1))
    $b serve --config "$conf/$case.json5" --listen "tcp/127.0.0.1:$port" 2> "$json.log" &
    local pid=$!
    sleep 1
    local peak=0 cpu0 cpu1 threads0 threads1
    cpu0=$(awk '{print $14 + $15}' "/proc/$pid/stat")
    threads0=$(thread_ticks $pid)
    # shellcheck disable=SC2046
    $lab loadgen $(load_args "$case") --connect "tcp/127.0.0.1:$port" --json > "$json" &
    local lg=$!
    while kill -0 $lg 2> /dev/null; do
      local rss; rss=$(awk '/VmRSS/{print $2}' "/proc/$pid/status" 2> /dev/null || echo 0)
      (( rss > peak )) && peak=$rss
      sleep 0.5
    done
    wait $lg
    cpu1=$(awk '{print $14 + $15}' "/proc/$pid/stat")
    threads1=$(thread_ticks $pid)
    kill -TERM $pid; wait $pid || true
    thread_shares "$threads0" "$threads1" > "$json.threads"
    echo "{\"cpu_s\": $(( cpu1 - cpu0 ))e-2, \"rss_peak_kb\": $peak}" > "$json.service"
  fi
  jq -s -r --arg l "$label" --arg c "$case" '.[0] * .[1] | [$c, $l, (.rate_per_s|floor), .lost, .rejected,
      (.p50_us/1000*100|round/100), (.p99_us/1000*100|round/100), (.max_us/1000*100|round/100),
      (if .cpu_s then (.cpu_s / .estimates * 1e7 | round / 10) else "-" end),
      (if .rss_peak_kb then (.rss_peak_kb/1024|round) else "-" end), (.send_lag_max_ms*10|round/10)]
      | @tsv' "$json" "$json.service"
  [[ -n $b ]] && echo "#   threads: $(cat "$json.threads")"
  return 0
}

echo "output: $out; $rounds round(s) of ${cases[*]}, $dur s each; binary $bin${other:+, other $other}; lab $lab"
printf 'case\trun\test/s\tlost\trej\tp50ms\tp99ms\tmaxms\tcpu_us/est\trssMB\tlag_ms\n'
for r in $(seq 1 "$rounds"); do
  step=$($lab bench --json --seconds 1 | jq '.qpf_us_per_step * 10 | round / 10')
  echo "# round $r: load average $(cut -d' ' -f1-3 /proc/loadavg), qpf:average step $step µs (bench)"
  for c in "${cases[@]}"; do
    run "$c" echo "" "$r"
    run "$c" service "$bin" "$r"
    [[ -n $other ]] && run "$c" other "$other" "$r"
  done
done
python3 - "$out" "$rounds" "${cases[@]}" <<'PY'
import json, os, statistics, sys
out, rounds, cases = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
load = lambda c, l, r: json.load(open(f"{out}/{c}-{l}-{r}.json"))
print("\nmedian over rounds of p99 / the same round's echo p99:")
for c in cases:
    for l in ("service", "other"):
        if not os.path.exists(f"{out}/{c}-{l}-1.json"):
            continue
        ratios = [load(c, l, r)["p99_us"] / load(c, "echo", r)["p99_us"] for r in range(1, rounds + 1)]
        lost = sum(load(c, l, r)["lost"] for r in range(1, rounds + 1))
        rate = statistics.median(load(c, l, r)["rate_per_s"] for r in range(1, rounds + 1))
        print(f"  {c:10s} {l:8s} p99 ratio {statistics.median(ratios):6.2f} (rounds: {', '.join(f'{x:.2f}' for x in ratios)}); "
              f"lost {lost}; estimates/s {rate:.0f}")
PY
