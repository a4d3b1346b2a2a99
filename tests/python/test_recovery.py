"""Nothing lost across a lossy link (proto/README.md, "Loss, recovery and back-pressure"), through the real binary
over zenoh, with the client's advanced publishers (eclipse-zenoh's zenoh-ext: a sequence number per put, a cache, a
heartbeat) against the service's advanced subscribers:

* a BROAD excerpt sent on `P/V/imu` in puts of 40 samples, while two busy loops keep both cores busy and the
  sender's link is cut for 2 s (a TCP proxy closes it and refuses to reconnect), gives the estimates of an idle,
  uncut run bit for bit, every sample processed, nothing refused and nothing reported missed; the same sender with
  plain puts loses what it put during the cut (so the test can fail);
* a spacecraft whose gyro (20 Hz) and star tracker (2 Hz, each set 0 to 0.5 s late) are two senders on two
  sessions, both cut for 2 s with every core busy: the last estimate of each `seq` is the in-order one, bit for
  bit (MEKF, USQUE, QPF);
* the BROAD sender across a restart of the service (SIGTERM, its checkpoints, a new process on the same state
  directory) while it keeps sending: the samples put while the service was down come from the sender's cache
  when it is back, those the checkpoint already held are skipped, and the estimates are the uninterrupted
  run's, bit for bit.

A cut makes the recovered samples late: `time.max_lag_s` is raised to cover it where two senders' streams must be
merged (the reorder window then fuses what comes late, as always).

Data: an excerpt of BROAD trial 16 committed in tests/data/broad (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021,
doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import contextlib
import signal
import threading
import time

import json
import json5
import numpy as np
import pytest
import zenoh
import zenoh.ext

from attitude_client import AttitudeClient
from attitude_client.replay import load_trial
from conftest import ROOT, Collector, ServiceProcess, free_port, subscribe_synced, wait_until
from attitude_client.tcp_proxy import TcpProxy
from test_imu_determinism import TRIAL
from test_late_data import cores_busy, spacecraft

#: The IMU vehicles: the preset's MEKF and a particle filter (200 particles, seeded by the vehicle id).
IMU_VEHICLES = {"rec-mekf": {"kind": "mekf"}, "rec-qpf": {"kind": "qpf", "particles": 200}}
#: Samples per put, and puts per wall second while sending (about 4 times the recording's rate).
BATCH = 40
PUTS_PER_S = 25.0
#: When the link is cut (s after the first put) and for how long.
CUT_AT_S, CUT_S = 1.5, 2.0
#: How long no service runs between the SIGTERM's exit and the next start, s.
DOWN_S = 1.0


def imu_service(extra: dict | None = None, args: list[str] | None = None, port: int | None = None):
    """A service with the IMU preset (config/imu.json5) and the test's vehicles."""
    preset = json5.loads((ROOT / "config" / "imu.json5").read_text())["service"]
    preset.pop("key_prefix", None)
    preset["vehicles"] = IMU_VEHICLES
    preset.update(extra or {})
    return ServiceProcess(preset, args=args, port=port)


def send_trial(client: AttitudeClient, trial: dict, cut=None, start_at: float = 0.0, during=None) -> dict:
    """The trial's samples to every IMU vehicle, ``BATCH`` per put, ``PUTS_PER_S`` puts a second. ``cut(i)`` may act
    before put ``i``; the puts made while ``during()`` is true are counted. Returns counts."""
    n = len(trial["t"])
    t0 = time.monotonic() if not start_at else start_at
    puts = counted = 0
    for k, start in enumerate(range(0, n, BATCH)):
        due = t0 + k / PUTS_PER_S
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        if cut is not None:
            cut(k)
        stop = min(n, start + BATCH)
        for v in IMU_VEHICLES:
            client.publish_imu(v, trial["t"][start:stop], trial["gyr"][start:stop], trial["acc"][start:stop],
                               trial["mag"][start:stop], batch=BATCH)
        puts += 1
        if during is not None and during():
            counted += 1
    return {"puts": puts, "during": counted}


def collect_estimates(estimates: Collector) -> dict:
    """The last estimate of each (vehicle, seq): a replayed estimate replaces the one of its seq."""
    last = {}
    for e in estimates.snapshot():
        last[(e["vehicle"], e["seq"])] = (e["t"], e["q"], e["bias"], e["cov"])
    return last


def wait_processed(c: AttitudeClient, vehicles, n: int, timeout: float = 60.0):
    def done():
        rows = {r["vehicle"]: r for r in c.vehicles()}
        return all(v in rows and rows[v]["processed"] + rows[v]["rejected"] >= n for v in vehicles)

    wait_until(done, timeout, f"every vehicle's {n} samples processed")
    return {r["vehicle"]: r for r in c.vehicles()}


def wait_estimates(estimates: Collector, rows: dict):
    wait_until(lambda: all(len({e["seq"] for e in estimates.where(vehicle=v)}) >= rows[v]["estimates"] for v in rows),
               20, "every estimate")


def imu_run(trial: dict, disturbed: bool, recovery: bool = True) -> tuple[dict, dict, dict]:
    """A fresh service; the trial from a sender behind a TCP proxy; with ``disturbed``, both cores busy and the
    proxy cut for ``CUT_S`` at ``CUT_AT_S``. Returns the estimates by (vehicle, seq), the health and the sender's
    counts."""
    svc = imu_service()
    proxy = None
    try:
        with svc.client(timeout=10.0) as c:
            svc.wait_ready(c)
            estimates = Collector()
            sub = subscribe_synced(c, c.subscribe_estimates, estimates)
            proxy = TcpProxy(("127.0.0.1", svc.port))
            with AttitudeClient(proxy.endpoint, prefix=svc.prefix, timeout=10.0, recovery=recovery) as sender:
                sender.wait_for_service(timeout=20.0)
                window = [0.0, 0.0]

                def cut(k: int) -> None:
                    if disturbed and k == int(CUT_AT_S * PUTS_PER_S):
                        window[0] = time.monotonic()
                        window[1] = window[0] + CUT_S
                        proxy.cut(CUT_S)

                with cores_busy() if disturbed else contextlib.nullcontext():
                    sent = send_trial(sender, trial, cut=cut,
                                      during=lambda: window[0] <= time.monotonic() <= window[1])
                    sent["reconnections"] = proxy.connections - 1
                    if recovery:
                        rows = wait_processed(c, IMU_VEHICLES, len(trial["t"]))
                    else:
                        # (Plain puts made during the cut are gone: wait for what did arrive.)
                        time.sleep(3.0)
                        rows = {r["vehicle"]: r for r in c.vehicles()}
            wait_estimates(estimates, rows)
            health = c.health()
            sub.undeclare()
            sent["rows"] = rows
    finally:
        if proxy is not None:
            proxy.close()
        code, _ = svc.stop()
        assert code == 0, svc.log()[-4000:]
    return collect_estimates(estimates), health, sent


@pytest.fixture(scope="module")
def trial():
    return load_trial(TRIAL, 6.0)


@pytest.fixture(scope="module")
def calm(trial):
    """The undisturbed run: estimates, health."""
    estimates, health, _ = imu_run(trial, disturbed=False)
    return estimates, health


def test_an_advanced_sender_cut_for_2_s_on_a_busy_machine_gives_the_undisturbed_estimates(trial, calm):
    n = len(trial["t"])
    calm, h_calm = calm
    rough, h_rough, sent = imu_run(trial, disturbed=True)
    print(f"\n{n} samples in {sent['puts']} puts per vehicle; {sent['during']} puts made during the {CUT_S} s cut, "
          f"{sent['reconnections']} reconnection(s); ingest {h_rough['ingest']}")
    # The cut happened and cost the sender puts that only its cache could give back.
    assert sent["reconnections"] >= 1 and sent["during"] >= 10, sent
    for h in (h_calm, h_rough):
        assert h["rejected"] == {} and h["missed"] == 0, h
        assert h["processed"] == h["received"] == len(IMU_VEHICLES) * n, h
    assert rough.keys() == calm.keys()
    diff = [k for k in calm if rough[k] != calm[k]]
    assert not diff, diff[:5]
    assert all(sum(1 for (v, _) in calm if v == veh) > n - 100 for veh in IMU_VEHICLES)


def test_a_plain_sender_cut_for_2_s_loses_what_it_put_meanwhile(trial):
    """The control: the same cut with plain puts (no sequence numbers, no cache) loses the puts made during it, and
    nobody can tell the sender (the lost puts never left its session)."""
    n = len(trial["t"])
    _, health, sent = imu_run(trial, disturbed=True, recovery=False)
    assert sent["reconnections"] >= 1 and sent["during"] >= 10, sent
    for v, row in sent["rows"].items():
        assert row["processed"] <= n - BATCH * (sent["during"] - 2), (v, row, sent)
    assert health["missed"] == 0, health


def test_puts_made_before_the_service_heard_of_a_publisher_come_from_its_cache(trial, calm):
    """A publisher whose first puts never reached the service (its link was not up yet) and that announces
    nothing (no publisher detection, no heartbeat): its first put that arrives is numbered 20, and the service
    fetches 0 to 19 from its cache before it (what zenoh-ext's own history query loses when a live put beats its
    answer, as after a restart of the service)."""
    n = len(trial["t"])
    calm, _ = calm
    vehicle = "rec-mekf"
    svc = imu_service()
    proxy = None
    try:
        with svc.client(timeout=10.0) as c:
            svc.wait_ready(c)
            estimates = Collector()
            sub = subscribe_synced(c, c.subscribe_estimates, estimates, vehicle)
            proxy = TcpProxy(("127.0.0.1", svc.port))
            proxy.cut(3600)
            config = zenoh.Config()
            config.insert_json5("mode", '"peer"')
            config.insert_json5("scouting/multicast/enabled", "false")
            config.insert_json5("connect/endpoints", json.dumps([proxy.endpoint]))
            sender = zenoh.open(config)
            try:
                pub = zenoh.ext.declare_advanced_publisher(
                    sender, f"{svc.prefix}/{vehicle}/imu", encoding=zenoh.Encoding.APPLICATION_JSON,
                    congestion_control=zenoh.CongestionControl.BLOCK, cache=zenoh.ext.CacheConfig(max_samples=256),
                    sample_miss_detection=zenoh.ext.MissDetectionConfig())
                puts = [
                    json.dumps([{"t": float(trial["t"][k]), "gyr": trial["gyr"][k].tolist(),
                                 "acc": trial["acc"][k].tolist(), "mag": trial["mag"][k].tolist()}
                                for k in range(start, min(n, start + BATCH))])
                    for start in range(0, n, BATCH)
                ]
                early = 20
                for p in puts[:early]:
                    pub.put(p)
                proxy.restore()

                def connected():
                    return any(r.ok is not None for r in sender.get(f"{svc.prefix}/@/health", timeout=0.5))

                wait_until(connected, 20, "the sender's link")
                for p in puts[early:]:
                    pub.put(p)
                    time.sleep(1.0 / PUTS_PER_S)
                rows = wait_processed(c, [vehicle], n)
                wait_estimates(estimates, {vehicle: rows[vehicle]})
                health = c.health()
                sub.undeclare()
                pub.undeclare()
            finally:
                sender.close()
    finally:
        if proxy is not None:
            proxy.close()
        code, _ = svc.stop()
        assert code == 0, svc.log()[-4000:]
    assert rows[vehicle]["processed"] == n and health["rejected"] == {} and health["missed"] == 0, (rows, health)
    got = collect_estimates(estimates)
    want = {k: x for k, x in calm.items() if k[0] == vehicle}
    assert got.keys() == want.keys(), sorted(set(got) ^ set(want))[:10]
    assert not [k for k in want if got[k] != want[k]]


SC_FILTERS = {"rc-mekf": {"kind": "mekf"}, "rc-usque": {"kind": "usque"}, "rc-qpf": {"kind": "qpf", "particles": 200}}
#: Simulated seconds per wall second (test_late_data's): the cut of 2 s is 4 s of sample time.
SPEED = 2.0


def spacecraft_run(two_senders: bool) -> tuple[dict, dict, dict]:
    """test_late_data's spacecraft: in order from one session, or from two sessions behind a proxy, in real time
    (times SPEED), sets late, both cut for 2 s with every core busy."""
    gyro, sets = spacecraft()
    # The recovered samples come up to the cut (4 s of sample time) late: fused if within the lag.
    svc = ServiceProcess({"vehicles": SC_FILTERS, "time": {"max_lag_s": 6.0}})
    proxy = None
    counts = {"during": 0}
    try:
        with svc.client(timeout=10.0) as c:
            svc.wait_ready(c)
            estimates, rejected = Collector(), Collector()
            subs = [subscribe_synced(c, c.subscribe_estimates, estimates),
                    subscribe_synced(c, c.subscribe_rejections, rejected)]
            if two_senders:
                proxy = TcpProxy(("127.0.0.1", svc.port))
                t0 = time.monotonic() + 1.0
                cut_at = t0 + 1.5
                window = (cut_at, cut_at + CUT_S)

                def cutter():
                    time.sleep(max(0.0, cut_at - time.monotonic()))
                    proxy.cut(CUT_S)

                def send(kind: str, items: list) -> None:
                    with AttitudeClient(proxy.endpoint, prefix=svc.prefix, timeout=10.0) as s:
                        s.wait_for_service(timeout=20.0)
                        for due, t, value in items:
                            delay = t0 + due / SPEED - time.monotonic()
                            if delay > 0:
                                time.sleep(delay)
                            if window[0] <= time.monotonic() <= window[1]:
                                counts["during"] += 1
                            for v in SC_FILTERS:
                                if kind == "gyro":
                                    s.publish_gyro(v, t, value)
                                else:
                                    s.publish_vectors(v, t, value)
                        # (A round trip once the link is back: everything put before has been delivered or
                        # is being recovered.)
                        s.health()

                threads = [threading.Thread(target=send, args=a) for a in (("gyro", gyro), ("vectors", sets))]
                threads.append(threading.Thread(target=cutter))
                with cores_busy():
                    for th in threads:
                        th.start()
                    for th in threads:
                        th.join()
                    counts["reconnections"] = proxy.connections - 2
            else:
                order = sorted([(t, 0, "gyro", w) for _, t, w in gyro] + [(t, 1, "vectors", o) for _, t, o in sets],
                               key=lambda x: (x[0], x[1]))
                for t, _, kind, value in order:
                    for v in SC_FILTERS:
                        (c.publish_gyro if kind == "gyro" else c.publish_vectors)(v, t, value)
            n = len(gyro) + len(sets)
            rows = wait_processed(c, SC_FILTERS, n, timeout=60.0)
            wait_estimates(estimates, rows)
            health = c.health()
            for sub in subs:
                sub.undeclare()
    finally:
        if proxy is not None:
            proxy.close()
        code, _ = svc.stop()
        assert code == 0, svc.log()[-4000:]
    assert rejected.snapshot() == [], rejected.snapshot()[:5]
    return collect_estimates(estimates), health, counts


def test_two_spacecraft_senders_cut_for_2_s_on_a_busy_machine_give_the_in_order_estimates():
    in_order, _, _ = spacecraft_run(two_senders=False)
    cut, health, counts = spacecraft_run(two_senders=True)
    print(f"\n{counts['during']} inputs sent during the cut, {counts.get('reconnections')} reconnection(s); "
          f"late fused {health['late_fused']}; ingest {health['ingest']}")
    assert counts["during"] >= 20 and counts["reconnections"] >= 1, counts
    assert health["rejected"] == {} and health["missed"] == 0, health
    for v in SC_FILTERS:
        mine = {k: x for k, x in cut.items() if k[0] == v}
        want = {k: x for k, x in in_order.items() if k[0] == v}
        assert mine.keys() == want.keys(), (v, sorted(set(mine) ^ set(want))[:10])
        diff = [k for k in want if mine[k] != want[k]]
        assert not diff, (v, diff[:5])


def test_a_service_restart_within_the_senders_cache_gives_the_uninterrupted_estimates(trial, calm, tmp_path):
    n = len(trial["t"])
    calm, _ = calm

    # The sender and the observer listen; the service connects to both as it starts (so that both are there
    # before it takes its first input), with its checkpoints in a state directory.
    sender_ep, observer_ep = (f"tcp/127.0.0.1:{free_port()}" for _ in range(2))
    state_dir = str(tmp_path)

    def start():
        return imu_service({"persistence": {"state_dir": state_dir, "checkpoint_interval_s": 3600.0}},
                           args=["--connect", sender_ep, "--connect", observer_ep])

    estimates = Collector()
    observer = AttitudeClient(observer_ep, connect=False, timeout=10.0, prefix="pytest/attitude")
    sender = AttitudeClient(sender_ep, connect=False, timeout=10.0, prefix="pytest/attitude")
    services = [start()]
    down = {}

    def restart_at(when: float) -> None:
        """SIGTERM at ``when`` (monotonic), then a new process on the same state directory; notes how long
        nobody answered."""
        time.sleep(max(0.0, when - time.monotonic()))
        down["t0"] = time.monotonic()
        code, _ = services[0].stop(signal.SIGTERM)
        down["code"] = code
        time.sleep(DOWN_S)
        services.append(start())
        while time.monotonic() < down["t0"] + 30:
            try:
                observer.health(timeout=0.1)
                down["t1"] = time.monotonic()
                return
            except Exception:  # noqa: BLE001 - not up yet
                pass

    try:
        services[0].wait_ready(observer)
        sub = subscribe_synced(observer, observer.subscribe_estimates, estimates)
        sender.wait_for_service(timeout=20.0)
        t0 = time.monotonic()
        restarter = threading.Thread(target=restart_at, args=(t0 + 3.0,))
        restarter.start()
        sent = send_trial(sender, trial, start_at=t0, during=lambda: "t0" in down and "t1" not in down)
        restarter.join()
        assert down["code"] == 0, services[0].log()[-4000:]
        services[-1].wait_ready(observer)
        rows = wait_processed(observer, IMU_VEHICLES, n)
        wait_estimates(estimates, rows)
        health = observer.health()
        sub.undeclare()
    finally:
        observer.close()
        sender.close()
        for svc in services:
            svc.stop()
    print(f"\nservice down {down.get('t1', float('nan')) - down['t0']:.2f} s, {sent['during']} of the sender's "
          f"{sent['puts']} puts made meanwhile; restored {health['checkpoints']['restored']}, ingest {health['ingest']}")
    # Puts made while no service ran: only the sender's cache has them.
    assert sent["during"] >= 20, sent
    assert health["checkpoints"]["restored"] == len(IMU_VEHICLES), health
    assert health["rejected"] == {} and health["missed"] == 0, health
    # The cache gave back what the checkpoint held already: skipped, not refused.
    assert health["ingest"]["redelivered"] > 0, health
    got = collect_estimates(estimates)
    assert got.keys() == calm.keys(), sorted(set(got) ^ set(calm))[:10]
    diff = [k for k in calm if got[k] != calm[k]]
    assert not diff, diff[:5]


#: The flood: puts of FLOOD_SAMPLES IMU samples (about 0.4 MB) on a vehicle, as fast as a plain sender with
#: congestion control BLOCK can, each more than the vehicle's queue takes (limits.queue_per_vehicle, 4096): the
#: dispatcher decodes every one and refuses it, the work of the service that a sender can outpace.
FLOOD_SAMPLES = 5000
FLOOD_S = 4.0


def told_of(rejected: Collector, prefix: str, vehicle: str) -> tuple[int, int, int]:
    """Of the rejections told about ``vehicle``'s IMU puts: how many puts its queue refused (a message each), how
    many were refused on arrival (told in messages that say how many), and in how many messages."""
    told = rejected.where(key=f"{prefix}/{vehicle}/imu")
    by_queue = [r for r in told if r["code"] == "queue_full" and "refused on arrival" not in r["message"]]
    on_arrival = [int(r["message"].split(" ", 1)[0]) for r in told if "refused on arrival" in r["message"]]
    return len(by_queue), sum(on_arrival), len(on_arrival)


def test_flooding_senders_are_slowed_or_told_and_starve_nobody():
    """Two plain senders flood a vehicle each; a third vehicle's inputs from another session all get through,
    queries are answered all along, and every flood put is accounted for: refused by the vehicle's queue with a
    message of its own, or refused on arrival and told (queue_full, with how many): none vanishes. One flooder's
    callback waits for room at a time (back-pressure: its sender is slowed), the other's puts are then refused."""
    svc = ServiceProcess({"filter": {"kind": "mekf"}, "ingest": {"pending_bytes_per_vehicle": 2 << 20}})
    rng = np.random.default_rng(5)
    flood = ("[" + ",".join(
        '{"t":%r,"gyr":[%r,0,0],"acc":[0,0,9.81],"mag":[0,15.6,-41.7]}' % (100.0 + i * 0.005, rng.normal(0, 1e-3))
        for i in range(FLOOD_SAMPLES)) + "]").encode()
    floods = ("flood1", "flood2")
    counts = {v: 0 for v in (*floods, "calm")}
    latencies: list[float] = []
    stop = threading.Event()
    try:
        with svc.client(timeout=10.0) as c:
            svc.wait_ready(c)
            rejected = Collector()
            sub = subscribe_synced(c, c.subscribe_rejections, rejected)

            def flooder(vehicle: str):
                with svc.client(timeout=10.0, recovery=False) as f:
                    f.wait_for_service()
                    while not stop.is_set():
                        f.put_raw(vehicle, "imu", flood)
                        counts[vehicle] += 1

            def calm():
                with svc.client(timeout=10.0) as s:
                    s.wait_for_service()
                    t = 0.0
                    while not stop.is_set():
                        s.publish_imu("calm", t, [0, 0, 0], [0, 0, 9.81], [0, 15.6, -41.7])
                        counts["calm"] += 1
                        t += 0.01
                        time.sleep(0.01)

            def prober():
                with svc.client(timeout=10.0) as p:
                    p.wait_for_service()
                    while not stop.is_set():
                        t0 = time.monotonic()
                        p.health()
                        latencies.append(time.monotonic() - t0)
                        time.sleep(0.05)

            threads = [threading.Thread(target=flooder, args=(v,)) for v in floods]
            threads += [threading.Thread(target=f) for f in (calm, prober)]
            for th in threads:
                th.start()
            time.sleep(FLOOD_S)
            stop.set()
            for th in threads:
                th.join()
            # Everything the floods put has been dispatched and told. A put's return means it left the sender, not
            # that the service has it: on a loaded machine the last ones arrive, wait for room, are decoded and told
            # well after the channel last looked empty, so the test waits for the tally (or 30 s: then the
            # assertions below say what is missing).
            wait_until(lambda: c.health()["ingest"]["depth"] == 0, 30, "the ingest channel to drain")
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline and not (
                    all(sum(told_of(rejected, svc.prefix, v)[:2]) >= counts[v] for v in floods)
                    and {r["vehicle"]: r["processed"] for r in c.vehicles()}.get("calm", 0) >= counts["calm"]):
                time.sleep(0.05)
            time.sleep(0.2)  # (anything told twice would arrive meanwhile)
            health = c.health()
            rows = {r["vehicle"]: r for r in c.vehicles()}
            sub.undeclare()
    finally:
        stop.set()
        code, _ = svc.stop()
        assert code == 0, svc.log()[-4000:]
    lat = np.sort(latencies)
    print(f"\n{len(floods)} floods of {len(flood) / 1e6:.2f} MB puts for {FLOOD_S} s; ingest {health['ingest']}; calm: "
          f"{counts['calm']} samples, processed {rows['calm']['processed']}; {len(lat)} queries, p50 "
          f"{lat[len(lat) // 2] * 1e3:.1f} ms, max {lat[-1] * 1e3:.1f} ms")
    on_arrival_all = 0
    for v in floods:
        by_queue, on_arrival, messages = told_of(rejected, svc.prefix, v)
        on_arrival_all += on_arrival
        print(f"  {v}: {counts[v]} puts, {by_queue} refused by the vehicle's queue, {on_arrival} on arrival in "
              f"{messages} messages")
        # Nothing vanished: every flood put was refused by the queue or on arrival, and told.
        assert by_queue + on_arrival == counts[v], (v, by_queue, on_arrival, counts)
    # The floods were too much: a sender was slowed, and what could not wait was refused on arrival.
    assert health["ingest"]["waited"] > 0 and health["ingest"]["refused"] > 0, health
    assert health["ingest"]["refused"] == on_arrival_all == health["rejected"].get("ingest_overflow", 0), health
    # The calm vehicle lost nothing, and the queries were answered all along.
    assert rows["calm"]["processed"] == counts["calm"] and rows["calm"]["rejected"] == 0, rows["calm"]
    assert len(lat) >= FLOOD_S / 0.05 / 4 and lat[-1] < 1.0, lat[-5:]
