#!/usr/bin/env python3
"""CPU accounting of a fleet (issue 19): the same load on one instance and on dynamic fleets of N members.

    scripts/fleet-cpu.py [--bin BINARY] [--lab LAB_BINARY] [--filter mekf|qpf:average] [--vehicles 500] [--rate 10]
                         [--duration 20] [--members 1,2,3,4] [--repeat 3] [--json FILE] [-- LOADGEN ARGS]

For each repeat and each N: N `serve` processes on loopback (N = 1: a lone `serve`, single mode; N > 1:
`serve --fleet`, members m1..mN, zenoh peers, each listening on its own port, m2.. connecting to m1),
started under `nice -n -19` (a shared machine's other jobs then take the other cores, not these), the
fleet given time to agree on its members, then the lab's `loadgen` (also under `nice -n -19`; --lab, default
target/release/attitude-lab) connecting to every
member sends the load: --vehicles vehicles, each a vector set and a gyro sample per tick at --rate Hz, for
--duration s. Each member's CPU seconds over the load (utime + stime of /proc/PID/stat, read before
loadgen starts and after it ends) are summed; the table shows the sum, its ratio to the lone instance's
of the same repeat, each member's share, the loadgen's own CPU, and what loadgen reports (lost, p50, p99).
CPU seconds, not wall time: two cores cannot show wall-clock scaling, and CPU seconds are robust to the
other jobs of a shared machine. The target of issue 19: sum(N) <= 1.2 x lone for every N.

With --routed the fleets' load is sent on routed keys (`loadgen --routed`: each input reaches its route's
owner, and its standby members in batches); the lone instance is always sent plain keys, as a single
instance is used today. Arguments after `--` go to every loadgen (`loadgen --help` says what it takes).
Only the Python standard library: runs without the project's .venv.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
from fleet_common import cpu_s, free_port, thread_cpu_s, zenohd  # noqa: E402 (scripts/ on sys.path: this script's folder)


def config_text(filter_spec: str, client: bool) -> str:
    kind, _, fiducial = filter_spec.partition(":")
    f = {"kind": kind}
    if fiducial:
        f["fiducial"] = fiducial
    if kind == "qpf":
        f["particles"] = 1000
    return json.dumps(
        {
            "zenoh": {"mode": "client" if client else "peer", "scouting": {"multicast": {"enabled": False}}},
            "service": {"filter": f},
        }
    )


def start_members(
    binary: str, n: int, workdir: pathlib.Path, config: pathlib.Path, tag: str, router: str | None, static: bool
):
    ports = [free_port() for _ in range(n)]
    procs = []
    env = dict(os.environ, RUST_LOG="info")
    for k in range(n):
        name = f"m{k + 1}"
        args = ["nice", "-n", "-19", binary, "serve", "--config", str(config), "--instance", name]
        if router:
            args += ["--connect", router]
        else:
            args += ["--listen", f"tcp/127.0.0.1:{ports[k]}"]
            if k > 0:
                args += ["--connect", f"tcp/127.0.0.1:{ports[0]}"]
        if n > 1 and static:
            # Static shards: the k-th of n even slices of the 16 routes, no fleet.
            lo, hi = 16 * k // n, 16 * (k + 1) // n - 1
            args += ["--routes", f"{lo:x}-{hi:x}"]
        elif n > 1:
            args += ["--fleet"]
        log = open(workdir / f"{tag}-{name}.log", "wb")
        procs.append((name, subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, env=env), log))
    return ports, procs


def wait_ready(procs, workdir: pathlib.Path, tag: str, static: bool, timeout: float = 30.0) -> None:
    """Until every member logs that it runs and (in a fleet) that it sees every member."""
    names = [name for name, _, _ in procs]
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        ready = True
        for name, proc, _ in procs:
            if proc.poll() is not None:
                raise SystemExit(f"{name} exited: {(workdir / f'{tag}-{name}.log').read_text()[-2000:]}")
            text = (workdir / f"{tag}-{name}.log").read_text(errors="replace")
            if "attitude-service running" not in text:
                ready = False
            elif len(procs) > 1 and not static:
                seen = re.findall(r"fleet members.*", text)
                if not seen or not all(f'"{m}"' in seen[-1] for m in names):
                    ready = False
        if ready:
            return
        time.sleep(0.2)
    raise SystemExit(f"the members did not see each other within {timeout} s (logs in {workdir})")


def stop(procs) -> None:
    for _, proc, _ in procs:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
    for _, proc, log in procs:
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()


def member_pid(proc: subprocess.Popen) -> int:
    """The service's pid (`nice` execs it: the same pid)."""
    return proc.pid


def run_one(args, n: int, workdir: pathlib.Path, config: pathlib.Path, loadgen_extra: list[str], tag: str) -> dict:
    router = None
    if args.router:
        port = free_port()
        router = f"tcp/127.0.0.1:{port}"
        rlog = open(workdir / f"{tag}-router.log", "wb")
        rproc = subprocess.Popen(
            ["nice", "-n", "-19", zenohd(), "-l", router, "--no-multicast-scouting"], stdout=rlog, stderr=subprocess.STDOUT
        )
        time.sleep(0.5)
    ports, procs = start_members(args.bin, n, workdir, config, tag, router, args.static)
    if router:
        procs.append(("router", rproc, rlog))
    try:
        wait_ready([p for p in procs if p[0] != "router"], workdir, tag, args.static)
        # Declarations settle, and the takeovers of the start are over (their grace: 2 s).
        time.sleep(3.0)
        before = {name: cpu_s(member_pid(p)) for name, p, _ in procs}
        threads_before = {name: thread_cpu_s(member_pid(p)) for name, p, _ in procs if name != "router"}
        cmd = ["nice", "-n", "-19", args.lab, "loadgen", "--vehicles", str(args.vehicles), "--rate", str(args.rate)]
        cmd += ["--duration", str(args.duration), "--json"]
        for p in [router] if router else [f"tcp/127.0.0.1:{p}" for p in ports]:
            cmd += ["--connect", p]
        if n > 1 and args.routed:
            cmd += ["--routed"]
        cmd += loadgen_extra
        t0 = time.monotonic()
        lg = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        _, status, usage = os.wait4(lg.pid, 0)
        out = lg.stdout.read().decode()
        err = lg.stderr.read().decode()
        wall = time.monotonic() - t0
        after = {name: cpu_s(member_pid(p)) for name, p, _ in procs}
        threads = {}
        for name, p, _ in procs:
            if name == "router":
                continue
            b = threads_before[name]
            for t, v in thread_cpu_s(member_pid(p)).items():
                threads[t] = threads.get(t, 0.0) + v - b.get(t, 0.0)
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"loadgen failed: {err[-2000:]}")
        report = json.loads(out.strip().splitlines()[-1])
        cpu = {name: after[name] - before[name] for name in before if name != "router"}
        return {
            "n": n,
            "cpu": cpu,
            "router_cpu": after["router"] - before["router"] if router else None,
            "sum": sum(cpu.values()),
            "threads": threads,
            "loadgen_cpu": usage.ru_utime + usage.ru_stime,
            "wall_s": wall,
            "report": report,
        }
    finally:
        stop(procs)


def main() -> None:
    argv = sys.argv[1:]
    extra: list[str] = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1 :]
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "attitude-service"))
    ap.add_argument("--lab", default=str(ROOT / "target" / "release" / "attitude-lab"), help="the binary of loadgen")
    ap.add_argument("--filter", default="mekf")
    ap.add_argument("--vehicles", type=int, default=500)
    ap.add_argument("--rate", type=float, default=10.0)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--members", default="1,2,3,4")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", help="also write every run as JSON into this file")
    ap.add_argument(
        "--static",
        action="store_true",
        help="N single instances each serving an even slice of the routes (serve --routes), not a fleet: "
        "the same split without membership or standby (use with --routed)",
    )
    ap.add_argument(
        "--router",
        action="store_true",
        help="a zenohd router in the middle (members and loadgen its clients), as config/fleet/instance.json5; its CPU is shown apart",
    )
    ap.add_argument(
        "--threads",
        action="store_true",
        help="after each run, the members' CPU by thread name (summed over the members), beside the lone instance's",
    )
    ap.add_argument(
        "--routed",
        action="store_true",
        help="fleets (N > 1) get their inputs on routed keys (loadgen --routed); the lone instance always on plain keys",
    )
    args = ap.parse_args(argv)
    members = [int(x) for x in args.members.split(",")]
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="fleet-cpu."))
    config = workdir / "service.json5"
    config.write_text(config_text(args.filter, args.router))
    print(
        f"# {args.filter}: {args.vehicles} vehicles x {args.rate:g} Hz (a vector set and a gyro sample each) "
        f"for {args.duration:g} s; binary {args.bin}; {'static route shards' if args.static else 'fleets'}' inputs "
        f"{'routed' if args.routed else 'plain'}{' through a zenohd router' if args.router else ''}"
        f"{'; loadgen ' + ' '.join(extra) if extra else ''}; logs in {workdir}",
        flush=True,
    )
    print(f"{'rep':>3} {'N':>2} {'sum CPU s':>9} {'x lone':>6}  {'members (CPU s)':<40} {'loadgen':>7} {'router':>6} "
          f"{'lost':>5} {'p50 ms':>7} {'p99 ms':>7}", flush=True)
    runs = []
    for rep in range(args.repeat):
        lone = None
        for n in members:
            r = run_one(args, n, workdir, config, extra, f"r{rep}-n{n}")
            r["repeat"] = rep
            if n == 1:
                lone = r["sum"]
            r["ratio"] = r["sum"] / lone if lone else None
            runs.append(r)
            rep_ = r["report"]
            shares = " ".join(f"{v:.2f}" for v in r["cpu"].values())
            ratio = f"{r['ratio']:.2f}" if r["ratio"] else "-"
            rc = f"{r['router_cpu']:.2f}" if r["router_cpu"] is not None else "-"
            print(
                f"{rep:>3} {n:>2} {r['sum']:>9.2f} {ratio:>6}  {shares:<40} {r['loadgen_cpu']:>7.2f} {rc:>6} "
                f"{rep_['lost']:>5} {rep_['p50_us'] / 1e3:>7.1f} {rep_['p99_us'] / 1e3:>7.1f}",
                flush=True,
            )
            if args.threads:
                base = next(x for x in runs if x["repeat"] == rep and x["n"] == 1)["threads"] if lone else {}
                names = sorted(set(r["threads"]) | set(base), key=lambda t: -r["threads"].get(t, 0.0))
                print("      threads (CPU s, summed over the members" + ("; the lone instance's beside)" if n > 1 and base else ")"))
                for t in names:
                    v = r["threads"].get(t, 0.0)
                    if v < 0.005 and base.get(t, 0.0) < 0.005:
                        continue
                    other = f"  {base.get(t, 0.0):7.2f}" if n > 1 and base else ""
                    print(f"        {t:<24} {v:7.2f}{other}", flush=True)
    print("\n# summary over the repeats: median (min-max)")
    print(f"{'N':>2} {'sum CPU s':>22} {'x lone':>20} {'largest member share':>22}")
    for n in members:
        rs = [r for r in runs if r["n"] == n]
        sums = [r["sum"] for r in rs]
        ratios = [r["ratio"] for r in rs if r["ratio"]]
        shares = [max(r["cpu"].values()) / r["sum"] for r in rs if r["sum"] > 0]
        fmt = lambda xs, p=2: f"{statistics.median(xs):.{p}f} ({min(xs):.{p}f}-{max(xs):.{p}f})" if xs else "-"
        print(f"{n:>2} {fmt(sums):>22} {fmt(ratios):>20} {fmt(shares):>22}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(runs, indent=1))


if __name__ == "__main__":
    main()
