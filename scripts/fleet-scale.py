#!/usr/bin/env python3
"""The largest fleet run this machine allows, measured (issue 19; DEPLOYMENT.md, "A plan to 100 000 vehicles").

    .venv/bin/python scripts/fleet-scale.py [--vehicles 10000] [--rate 1] [--duration 60] [--members 4]
                                            [--filter mekf] [--bin BINARY] [--lab LAB_BINARY] [--json FILE]

Two zenohd routers (R2 connects to R1: two sites), `--members` instances of a dynamic fleet (`serve
--fleet`, zenoh clients, half on each router), and `attitude-lab loadgen --routed` on R2 sending every vehicle's
vector set and gyro sample at `--rate` Hz (routed keys, and batches for the routes' standby members) and
receiving every estimate. Measured over the load: each process's CPU seconds (/proc/PID/stat), the bytes
every TCP connection carried (`ss -tin`: bytes_received and bytes_acked at the start and the end, by
process), each member's inputs received one by one, routes, standby data (`P/@/instance/*/health`), and
what loadgen reports. Printed: per member and per router, CPU (cores) and bytes per second in and out;
per member inputs and estimates per second over the load (differences of its health's counters) next to
DEPLOYMENT.md's arithmetic for this load. The largest run here (2 cores): 30 000 vehicles at 1 Hz, after
which the members and routers use 1.7 cores and the load generator the rest.

Needs the project's .venv (scripts/python-tests.sh makes it: zenoh and the Python client) and zenohd
(scripts/ensure-zenohd.sh, run by this script).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import re
import signal
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "clients" / "python" / "src"))
from fleet_common import cpu_s, free_port, zenohd  # noqa: E402 (scripts/ on sys.path: this script's folder)


def sockets() -> dict[tuple[int, str, str], tuple[int, int]]:
    """(pid, local, peer) -> (bytes received, bytes sent and acknowledged) of every TCP connection."""
    out = subprocess.run(["ss", "-tinpH"], capture_output=True, text=True).stdout.splitlines()
    conns = {}
    head = None
    for line in out:
        if not line[:1].isspace():
            head = line
            continue
        if head is None:
            continue
        f = head.split()
        m = re.search(r"pid=(\d+)", head)
        if len(f) >= 5 and m:
            rx = re.search(r"bytes_received:(\d+)", line)
            tx = re.search(r"bytes_acked:(\d+)", line)
            conns[(int(m.group(1)), f[3], f[4])] = (int(rx.group(1)) if rx else 0, int(tx.group(1)) if tx else 0)
        head = None
    return conns


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "attitude-service"))
    ap.add_argument("--lab", default=str(ROOT / "target" / "release" / "attitude-lab"), help="the binary of loadgen")
    ap.add_argument("--vehicles", type=int, default=10000)
    ap.add_argument("--rate", type=float, default=1.0)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--members", type=int, default=4)
    ap.add_argument("--filter", default="mekf")
    ap.add_argument("--json", help="write the figures as JSON into this file")
    args = ap.parse_args()
    from attitude_client import AttitudeClient
    import zenoh

    work = pathlib.Path(tempfile.mkdtemp(prefix="fleet-scale."))
    p1, p2 = free_port(), free_port()
    r1, r2 = f"tcp/127.0.0.1:{p1}", f"tcp/127.0.0.1:{p2}"
    kind, _, fiducial = args.filter.partition(":")
    conf = {
        "zenoh": {"mode": "client", "scouting": {"multicast": {"enabled": False}}},
        "service": {
            "filter": {"kind": kind, **({"fiducial": fiducial} if fiducial else {})},
            # Every vehicle of the run fits one member (the default is 10 000).
            "limits": {"max_vehicles": args.vehicles + 100},
            "metrics": {"max_vehicles": 0},
        },
    }
    (work / "member.json5").write_text(json.dumps(conf))
    procs: dict[str, subprocess.Popen] = {}
    logs = []

    def start(name: str, argv: list[str]) -> None:
        log = open(work / f"{name}.log", "wb")
        logs.append(log)
        procs[name] = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT)

    zd = zenohd()
    try:
        start("R1", ["nice", "-n", "-19", zd, "-l", r1, "--no-multicast-scouting"])
        start("R2", ["nice", "-n", "-19", zd, "-l", r2, "-e", r1, "--no-multicast-scouting"])
        time.sleep(1.0)
        names = [f"m{k + 1}" for k in range(args.members)]
        for k, name in enumerate(names):
            router = r1 if k % 2 == 0 else r2
            start(name, ["nice", "-n", "-19", args.bin, "serve", "--config", str(work / "member.json5"), "--fleet",
                         "--instance", name, "--connect", router])
        c = zenoh.Config()
        c.insert_json5("mode", '"client"')
        c.insert_json5("connect/endpoints", json.dumps([r1]))
        op = AttitudeClient(r1, config=c)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            hs = op.instances(timeout=5)
            if len(hs) == args.members and all(len(h["fleet"]["members"]) == args.members for h in hs.values()):
                break
            time.sleep(0.5)
        else:
            raise SystemExit(f"the fleet did not form (logs in {work})")
        time.sleep(3.0)  # the takeovers of the start and their grace
        healths0 = op.instances(timeout=5)
        pids = {n: p.pid for n, p in procs.items()}
        cpu0 = {n: cpu_s(pid) for n, pid in pids.items()}
        socks0 = sockets()
        t0 = time.monotonic()
        lg = subprocess.run(
            ["nice", "-n", "-19", args.lab, "loadgen", "--vehicles", str(args.vehicles), "--rate", str(args.rate),
             "--duration", str(args.duration), "--connect", r2, "--routed", "--json"],
            capture_output=True, text=True,
        )
        wall = time.monotonic() - t0
        cpu1 = {n: cpu_s(pid) for n, pid in pids.items()}
        socks1 = sockets()
        if lg.returncode != 0:
            raise SystemExit(f"loadgen failed: {lg.stderr[-2000:]}")
        report = json.loads(lg.stdout.strip().splitlines()[-1])
        healths = op.instances(timeout=5)
        op.close()
    finally:
        for p in procs.values():
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in procs.values():
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
        for log in logs:
            log.close()

    # Bytes per process over the load, and per router link.
    by_pid: dict[int, list[int]] = {}
    for key, (rx1, tx1) in socks1.items():
        rx0, tx0 = socks0.get(key, (0, 0))
        b = by_pid.setdefault(key[0], [0, 0])
        b[0] += rx1 - rx0
        b[1] += tx1 - tx0
    rows = []
    for name, pid in pids.items():
        rx, tx = by_pid.get(pid, [0, 0])
        row = {"process": name, "cpu_s": cpu1[name] - cpu0[name], "cpu_share": (cpu1[name] - cpu0[name]) / wall,
               "rx_bytes_s": rx / wall, "tx_bytes_s": tx / wall}
        if name in healths:
            h = healths[name]
            row.update(
                inputs_s=(h["received"] - healths0[name]["received"]) / wall,
                estimates_s=(h["estimates_published"] - healths0[name]["estimates_published"]) / wall,
                routes_owned=len(h["fleet"]["routes_owned"]),
                routes_standby=len(h["fleet"]["routes_standby"]),
                vehicles=h["vehicles"],
                standby_bytes=h["fleet"]["standby_bytes"],
            )
        rows.append(row)
    inputs = 2 * args.vehicles * args.rate
    print(f"# {args.vehicles} vehicles x {args.rate:g} Hz ({inputs:.0f} inputs/s, {args.vehicles * args.rate:.0f} "
          f"estimates/s), {args.filter}, {args.members} members on two zenohd routers, {args.duration:g} s; logs in {work}")
    print(f"loadgen: sent {report['sent']} sets + {report['gyro_sent']} gyro, {report['estimates']} answered, "
          f"lost {report['lost']}, p50 {report['p50_us'] / 1e3:.1f} ms, p99 {report['p99_us'] / 1e3:.1f} ms, "
          f"send lag max {report['send_lag_max_ms']:.0f} ms")
    print(f"{'process':>8} {'CPU (cores)':>11} {'in MB/s':>8} {'out MB/s':>9} {'inputs/s':>9} {'vehicles':>8} "
          f"{'routes':>7} {'standby MB':>10}")
    for r in rows:
        extra = (f"{r['inputs_s']:>9.0f} {r['vehicles']:>8} {r['routes_owned']:>3}+{r['routes_standby']:<3} "
                 f"{r['standby_bytes'] / 1e6:>10.1f}") if "inputs_s" in r else ""
        print(f"{r['process']:>8} {r['cpu_share']:>11.3f} {r['rx_bytes_s'] / 1e6:>8.2f} {r['tx_bytes_s'] / 1e6:>9.2f} {extra}")
    # DEPLOYMENT.md's arithmetic for this load: a member owning o of the 16 routes receives o/16 of the
    # inputs one by one and, holding s more, s/16 of them again in its senders' batches (4 a second per
    # route) plus its owners' batches of estimates (2 a second per route); every input and estimate
    # crosses the link between the routers at most once per direction it is needed.
    sets = args.vehicles * args.rate
    print("\n# the arithmetic beside (o routes owned, s kept standby): inputs/s = o/16 x "
          f"{inputs:.0f}; batches/s in = s x (4 + 2); estimates/s = o/16 x {sets:.0f}")
    for r in rows:
        if "inputs_s" not in r:
            continue
        o, sb = r["routes_owned"], r["routes_standby"]
        print(f"{r['process']:>8} inputs/s {r['inputs_s']:>8.0f} (arithmetic {o / 16 * inputs:>8.0f}), estimates/s "
              f"{r['estimates_s']:>7.0f} (arithmetic {o / 16 * sets:>7.0f}), batches/s in (arithmetic) {sb * 6:>4}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps({"args": vars(args), "loadgen": report, "rows": rows, "wall_s": wall}, indent=1))


if __name__ == "__main__":
    main()
