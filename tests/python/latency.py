"""Latency of the service against bare zenoh, measured the same way from Python.

    .venv/bin/python tests/python/latency.py [--samples 200]

starts the release binary on a free port and prints median / p99 of:
* put → estimate: publish a vector-observation set for a tracking vehicle, until its estimate arrives
  (one in flight at a time), per filter;
* get → reply of the service's queryables (`P/V/attitude`, `P/@/health`);
* bare zenoh: Python put → Python subscriber on another session that puts it back → Python subscriber
  (the same path shape as put → estimate, without the service), Python put → Python subscriber (one way),
  and Python get → Python queryable.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import threading
import time

import numpy as np
import zenoh

from sim import Scenario, to_wire


def stats_us(samples_s: list[float]) -> dict:
    us = sorted(x * 1e6 for x in samples_s)
    p99 = us[min(len(us) - 1, int(round(0.99 * (len(us) - 1))))]
    return {"n": len(us), "median_us": statistics.median(us), "p99_us": p99, "max_us": us[-1]}


def fmt(name: str, s: dict) -> str:
    return f"{name:<58} median {s['median_us']:8.0f} µs   p99 {s['p99_us']:8.0f} µs   (n = {s['n']})"


def put_to_estimate(client, vehicle: str, samples: int, warmup: int = 10, timeout: float = 5.0) -> dict:
    """Resets ``vehicle`` to a still truth, then publishes one vector set at a time and times until its
    estimate arrives (one in flight)."""
    scenario = Scenario(seed=99, rate_rad_s=np.zeros(3))
    t0 = 1000.0 + round(time.time() % 1000)  # after anything the vehicle has seen
    client.reset(vehicle, q=to_wire(scenario.truth(t0)), sigma_deg=0.01, t=t0 - 1.0)
    arrived: dict[float, float] = {}
    refused: list[dict] = []
    cond = threading.Condition()

    def on_estimate(e):
        now = time.perf_counter()
        with cond:
            arrived[e["t"]] = now
            cond.notify_all()

    def on_rejected(r):
        with cond:
            refused.append(r)
            cond.notify_all()

    subs = [client.subscribe_estimates(on_estimate, vehicle=vehicle),
            client.subscribe_rejections(on_rejected, vehicle=vehicle)]
    client.health()  # the service knows the subscribers now
    out = []
    try:
        for i in range(samples + warmup):
            t = t0 + i
            obs = scenario.vectors(t)
            start = time.perf_counter()
            client.publish_vectors(vehicle, t, obs)
            with cond:
                if not cond.wait_for(lambda: t in arrived or refused, timeout):
                    raise TimeoutError(f"{vehicle}: no estimate for t = {t}")
                if refused:
                    raise RuntimeError(f"{vehicle}: the service refused a vector set: {refused}")
                if i >= warmup:
                    out.append(arrived[t] - start)
    finally:
        for sub in subs:
            sub.undeclare()
    return stats_us(out)


def get_latency(client, call, samples: int, warmup: int = 10) -> dict:
    out = []
    for i in range(samples + warmup):
        start = time.perf_counter()
        call()
        if i >= warmup:
            out.append(time.perf_counter() - start)
    return stats_us(out)


def _session(listen: str | None = None, connect: str | None = None) -> zenoh.Session:
    c = zenoh.Config()
    c.insert_json5("mode", '"peer"')
    c.insert_json5("scouting/multicast/enabled", "false")
    c.insert_json5("listen/endpoints", json.dumps([listen] if listen else []))
    c.insert_json5("connect/endpoints", json.dumps([connect] if connect else []))
    return zenoh.open(c)


def bare_zenoh(port: int, samples: int, warmup: int = 10) -> dict[str, dict]:
    """Python ↔ Python over one loopback TCP link (session B listens, session A connects)."""
    b = _session(listen=f"tcp/127.0.0.1:{port}")
    a = _session(connect=f"tcp/127.0.0.1:{port}")
    results = {}
    try:
        # Echo: A puts bench/ping; B's subscriber puts it back on bench/pong; A's subscriber times it.
        def echo(sample):
            b.put("bench/pong", sample.payload.to_bytes(), congestion_control=zenoh.CongestionControl.BLOCK)

        got: dict[int, float] = {}
        cond = threading.Condition()

        def on_pong(sample):
            now = time.perf_counter()
            with cond:
                got[int(sample.payload.to_string())] = now
                cond.notify_all()

        sub_b = b.declare_subscriber("bench/ping", echo)
        sub_a = a.declare_subscriber("bench/pong", on_pong)

        def ready():
            # Declarations propagate asynchronously: ping until pongs come back.
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                a.put("bench/ping", "-1")
                with cond:
                    if cond.wait_for(lambda: -1 in got, 0.05):
                        return
            raise TimeoutError("bare zenoh echo did not start")

        ready()
        rtt = []
        for i in range(samples + warmup):
            start = time.perf_counter()
            a.put("bench/ping", str(i), congestion_control=zenoh.CongestionControl.BLOCK)
            with cond:
                if not cond.wait_for(lambda: i in got, 5):
                    raise TimeoutError(f"no pong {i}")
                if i >= warmup:
                    rtt.append(got[i] - start)
        results["bare: Python put → Python sub + put back → Python sub"] = stats_us(rtt)

        # One way: A puts bench/oneway with its send time; B's subscriber timestamps arrival (same clock).
        one: dict[int, float] = {}
        sent: dict[int, float] = {}

        def on_one(sample):
            now = time.perf_counter()
            with cond:
                one[int(sample.payload.to_string())] = now
                cond.notify_all()

        sub_one = b.declare_subscriber("bench/oneway", on_one)
        deadline = time.monotonic() + 10
        while -1 not in one and time.monotonic() < deadline:
            a.put("bench/oneway", "-1")
            time.sleep(0.02)
        for i in range(samples + warmup):
            sent[i] = time.perf_counter()
            a.put("bench/oneway", str(i), congestion_control=zenoh.CongestionControl.BLOCK)
            with cond:
                cond.wait_for(lambda: i in one, 5)
        results["bare: Python put → Python sub (one way)"] = stats_us(
            [one[i] - sent[i] for i in range(warmup, samples + warmup)]
        )

        # Get → queryable.
        def on_query(query):
            with query:
                query.reply(query.key_expr, b"{}")

        qbl = b.declare_queryable("bench/q", on_query)

        def get():
            for reply in a.get("bench/q", consolidation=zenoh.ConsolidationMode.NONE, timeout=5):
                assert reply.ok is not None
                return
            raise TimeoutError("no reply")

        deadline = time.monotonic() + 10
        while True:
            try:
                get()
                break
            except TimeoutError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.02)
        results["bare: Python get → Python queryable → reply"] = get_latency(None, get, samples, warmup)
        for s in (sub_a, sub_b, sub_one, qbl):
            s.undeclare()
    finally:
        a.close()
        b.close()
    return results


def measure(service, client, samples: int, vehicles: dict[str, str]) -> dict[str, dict]:
    """Every figure: ``vehicles`` maps a vehicle id (configured with that filter) to a label."""
    from conftest import free_port

    results = {}
    for vehicle, label in vehicles.items():
        results[f"service: put vectors → estimate ({label})"] = put_to_estimate(client, vehicle, samples)
    first = next(iter(vehicles))
    results["service: get P/V/attitude → reply"] = get_latency(client, lambda: client.get_attitude(first), samples)
    results["service: get P/@/health → reply"] = get_latency(client, client.health, samples)
    results.update(bare_zenoh(free_port(), samples))
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--json", help="also write the figures to this file")
    args = parser.parse_args()
    from conftest import ServiceProcess

    vehicles = {"lat-mekf": "mekf", "lat-usque": "usque", "lat-qpf": "qpf, 1000 particles"}
    svc = ServiceProcess(
        {"vehicles": {"lat-mekf": {"kind": "mekf"}, "lat-usque": {"kind": "usque"}, "lat-qpf": {"kind": "qpf"}}},
        prefix="latency",
    )
    try:
        with svc.client() as client:
            svc.wait_ready(client)
            results = measure(svc, client, args.samples, vehicles)
    finally:
        code, _ = svc.stop()
    for name, s in results.items():
        print(fmt(name, s))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    return 0 if code == 0 else 1


if __name__ == "__main__":
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent))
    sys.exit(main())
