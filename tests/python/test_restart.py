"""Persistence across restarts (proto/README.md, "Checkpoints"): after SIGTERM nothing is lost and the
restarted service continues exactly as an uninterrupted one; after SIGKILL at most one checkpoint
interval is lost; a corrupt checkpoint file is reported and skipped."""

from __future__ import annotations

import pathlib
import signal
import time

import pytest

from conftest import Collector, ServiceProcess, subscribe_synced, validate
from sim import Scenario

VEHICLES = {
    "r-qpf": {"kind": "qpf", "particles": 300},
    "r-usque": {"kind": "usque"},
    "r-mekf": {"kind": "mekf"},
}


def start(state_dir: str, interval_s: float = 3600.0) -> tuple[ServiceProcess, object]:
    svc = ServiceProcess(
        {
            "vehicles": VEHICLES,
            "persistence": {"state_dir": state_dir, "checkpoint_interval_s": interval_s},
        }
    )
    c = svc.client()
    svc.wait_ready(c)
    return svc, c


def stream(client, chunks, vehicles=VEHICLES):
    for ch in chunks:
        for v in vehicles:
            client.publish_gyro_batch(v, ch.gyro)
            client.publish_vectors(v, ch.t, ch.obs)


def wait_estimates(client, collector: Collector, t_last: float, timeout: float = 30.0):
    collector.wait_for(
        lambda items: all(any(e["vehicle"] == v and e["t"] >= t_last for e in items) for v in VEHICLES),
        timeout,
        f"every vehicle's estimate at t = {t_last}",
    )


def states(client) -> dict:
    return {v: client.get_state(v) for v in VEHICLES}


def stop(svc, c, sig=signal.SIGTERM):
    c.close()
    code, _ = svc.stop(sig)
    return code


def test_sigterm_loses_nothing_and_the_restart_changes_nothing(tmp_path):
    chunks = Scenario(seed=41, duration_s=60.0).chunks()
    first, second = chunks[:31], chunks[31:]  # t = 0..30, then 31..60
    (tmp_path / "state").mkdir()
    (tmp_path / "ref").mkdir()
    state_dir = str(tmp_path / "state")

    # The reference: one service, never restarted.
    ref, rc = start(str(tmp_path / "ref"))
    got = Collector()
    sub = subscribe_synced(rc, rc.subscribe_estimates, got)
    stream(rc, chunks)
    wait_estimates(rc, got, 60.0)
    final_ref = states(rc)
    sub.undeclare()
    assert stop(ref, rc) == 0

    # The same inputs with a SIGTERM and a restart after t = 30 s.
    a, ac = start(state_dir)
    got = Collector()
    sub = subscribe_synced(ac, ac.subscribe_estimates, got)
    stream(ac, first)
    wait_estimates(ac, got, 30.0)
    before = states(ac)
    sub.undeclare()
    assert stop(a, ac) == 0
    files = sorted(p.name for p in pathlib.Path(state_dir).iterdir())
    assert files == sorted(f"{v}.ckpt" for v in VEHICLES), files

    b, bc = start(state_dir)
    try:
        h = bc.health()
        validate("health", h)
        assert h["checkpoints"]["restored"] == len(VEHICLES), h
        assert h["checkpoints"]["skipped"] == 0, h
        after = states(bc)
        for v in VEHICLES:
            # The attitude and covariance right after the restart are those before the SIGTERM, exactly.
            assert after[v]["q"] == before[v]["q"], v
            assert after[v]["cov"] == before[v]["cov"], v
            assert after[v]["t"] == before[v]["t"] == 30.0, v
            assert after[v]["seq"] == before[v]["seq"], v
        rows = {r["vehicle"]: r for r in bc.vehicles()}
        assert all(rows[v]["received"] > 0 and rows[v]["rejected"] == 0 for v in VEHICLES), rows
        got = Collector()
        sub = subscribe_synced(bc, bc.subscribe_estimates, got)
        stream(bc, second)
        wait_estimates(bc, got, 60.0)
        final = states(bc)
        sub.undeclare()
        print("\nrestart (SIGTERM at t = 30 s):")
        for v in VEHICLES:
            print(f"  {v:8s} before q={before[v]['q']} sigma_deg={before[v]['sigma_deg']}")
            print(f"  {'':8s} after  q={after[v]['q']} sigma_deg={after[v]['sigma_deg']}")
            # Particles, weights and random-number state were restored: the particle filter continues
            # exactly as the uninterrupted one.
            assert final[v]["q"] == final_ref[v]["q"], v
            assert final[v]["cov"] == final_ref[v]["cov"], v
    finally:
        assert stop(b, bc) == 0


def test_sigkill_loses_at_most_one_checkpoint_interval(tmp_path):
    interval = 1.0
    state_dir = str(tmp_path)
    svc, c = start(state_dir, interval_s=interval)
    got = Collector()
    sub = subscribe_synced(c, c.subscribe_estimates, lambda e: got((time.monotonic(), e)))
    chunks = Scenario(seed=43, duration_s=60.0).chunks()
    # About 10 sets per wall second for 4 s, then SIGKILL.
    sent = 0
    t_start = time.monotonic()
    for ch in chunks:
        if time.monotonic() - t_start > 4.0:
            break
        stream(c, [ch])
        sent += 1
        time.sleep(0.1)
    time.sleep(0.3)
    killed_at = time.monotonic()
    sub.undeclare()
    c.close()
    svc.stop(signal.SIGKILL)
    seen = got.snapshot()
    # What every vehicle had published one interval (plus scheduling slack) before the kill.
    cutoff = killed_at - interval - 0.3
    floor = {
        v: max((e["t"] for (w, e) in seen if e["vehicle"] == v and w <= cutoff), default=0.0) for v in VEHICLES
    }
    last = {v: max(e["t"] for (_, e) in seen if e["vehicle"] == v) for v in VEHICLES}
    b, bc = start(state_dir, interval_s=interval)
    try:
        h = bc.health()
        assert h["checkpoints"]["restored"] == len(VEHICLES), h
        restored = {v: bc.get_state(v)["t"] for v in VEHICLES}
        print(f"\nSIGKILL after {sent} sets: last published t {last}, restored t {restored}, floor {floor}")
        for v in VEHICLES:
            assert floor[v] <= restored[v] <= last[v], (v, floor[v], restored[v], last[v])
        # The restored vehicles keep tracking.
        t_next = max(restored.values()) + 1.0
        more = [ch for ch in chunks if ch.t >= t_next][:5]
        got2 = Collector()
        sub2 = subscribe_synced(bc, bc.subscribe_estimates, got2)
        stream(bc, more)
        wait_estimates(bc, got2, more[-1].t)
        sub2.undeclare()
    finally:
        assert stop(b, bc) == 0


def test_a_corrupt_checkpoint_is_reported_and_skipped(tmp_path):
    state_dir = str(tmp_path)
    a, ac = start(state_dir)
    got = Collector()
    sub = subscribe_synced(ac, ac.subscribe_estimates, got)
    stream(ac, Scenario(seed=47, duration_s=5.0).chunks())
    wait_estimates(ac, got, 5.0)
    sub.undeclare()
    assert stop(a, ac) == 0
    d = pathlib.Path(state_dir)
    good = (d / "r-mekf.ckpt").read_bytes()
    (d / "r-mekf.ckpt").write_bytes(good[: len(good) // 2])  # a partial write
    (d / "junk.ckpt").write_bytes(b"\x00" * 100)
    # A checkpoint of the previous format (format 3, the golden file kept in the repository).
    old = pathlib.Path(__file__).parents[1] / "data" / "checkpoints" / "v3-qpf-imu.ckpt"
    (d / "golden-qpf-imu.ckpt").write_bytes(old.read_bytes())
    b, bc = start(state_dir)
    try:
        h = bc.health()
        assert h["checkpoints"]["skipped"] == 3, h
        assert h["checkpoints"]["restored"] == len(VEHICLES) - 1, h
        assert {r["vehicle"] for r in bc.vehicles()} == set(VEHICLES) - {"r-mekf"}
        assert bc.get_state("r-qpf")["t"] == 5.0
    finally:
        assert stop(b, bc) == 0
    log = b.log()
    assert "checkpoint skipped" in log, log[-2000:]
    assert "golden-qpf-imu.ckpt: not a checkpoint (format version 3, written by an earlier build" in log, (
        log[-3000:]
    )
