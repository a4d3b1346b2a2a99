"""Time order over the network (proto/README.md, "Time order, outliers and failures"): the reorder window
merges a vehicle's gyro and vector streams in time order, a set later than the window is fused by a replay
(published again with the `seq` it replaces), one older than `time.max_lag_s` is refused, a gyro gap is
flagged and inflates the uncertainty, and a put on a wildcard vehicle chunk is refused on P/@/rejected only.
(tests/python/test_late_data.py: late data under load, bit for bit.)"""

from __future__ import annotations

import json

from conftest import PREFIX, Collector, subscribe_synced, wait_until
from sim import Scenario


def test_vectors_ahead_of_the_gyro_stream_wait_for_it(client):
    vehicle = "to-reorder"
    s = Scenario(seed=51, duration_s=3.0)
    estimates, rejected = Collector(), Collector()
    subs = [
        subscribe_synced(client, client.subscribe_estimates, estimates, vehicle=vehicle),
        subscribe_synced(client, client.subscribe_rejections, rejected, vehicle=vehicle),
    ]
    gyro = {round(t, 1): s.gyro(t) for t in [i / 10 for i in range(31)]}
    # (Within the window the sets wait for the gyro; later ones would be fused by a replay: the next test.)
    client.publish_gyro_batch(vehicle, [(t, gyro[t]) for t in [0.0, 0.1]])
    client.publish_vectors(vehicle, 0.0, s.vectors(0.0))
    client.publish_gyro_batch(vehicle, [(t, gyro[t]) for t in [0.2, 0.3, 0.4, 0.5]])
    # The sets at 1 s and 2 s arrive before the gyro samples that precede them.
    client.publish_vectors(vehicle, 1.0, s.vectors(1.0))
    client.publish_gyro_batch(vehicle, [(t, gyro[t]) for t in [0.6, 0.7, 0.8, 0.9, 1.0]])
    client.publish_vectors(vehicle, 2.0, s.vectors(2.0))
    client.publish_gyro_batch(vehicle, [(round(1.1 + i / 10, 1), gyro[round(1.1 + i / 10, 1)]) for i in range(20)])
    got = estimates.wait_for(lambda i: len(i) >= 3, 10, "three estimates")
    client.health()
    for sub in subs:
        sub.undeclare()
    assert rejected.snapshot() == []
    assert [e["t"] for e in got] == [0.0, 1.0, 2.0]
    # The gyro samples after the last set leave the window by wall time.
    row = lambda: next(r for r in client.vehicles() if r["vehicle"] == vehicle)  # noqa: E731
    wait_until(lambda: row()["processed"] == 31 + 3, 10, "every sample processed")
    assert row()["received"] == 31 + 3 and row()["rejected"] == 0, row()


def test_a_set_later_than_the_window_is_fused_and_one_beyond_the_lag_refused(client):
    vehicle = "to-late"
    s = Scenario(seed=52, duration_s=6.0)
    estimates, rejected = Collector(), Collector()
    subs = [
        subscribe_synced(client, client.subscribe_estimates, estimates, vehicle=vehicle),
        subscribe_synced(client, client.subscribe_rejections, rejected, vehicle=vehicle),
    ]
    gyro = [(i / 10, s.gyro(i / 10)) for i in range(61)]
    client.publish_vectors(vehicle, 0.0, s.vectors(0.0))
    client.publish_gyro_batch(vehicle, gyro[:11])
    client.publish_vectors(vehicle, 2.0, s.vectors(2.0))
    client.publish_gyro_batch(vehicle, gyro[11:26])  # to 2.5 s: the set at 2 s is used
    estimates.wait_for(lambda i: len(i) >= 2, 10, "the estimates at 0 and 2 s")
    # The set at 1 s, long after the gyro passed its time (beyond the 0.2 s window, within the 2 s lag behind the
    # vehicle's last sample, 2.3 to 2.5 s): fused; the set at 2 s is estimated again after it, with the next seq.
    client.publish_vectors(vehicle, 1.0, s.vectors(1.0))
    got = estimates.wait_for(lambda i: len(i) >= 4, 10, "the replayed estimates")
    assert [(e["t"], e["seq"], e["diagnostics"].get("replayed", False)) for e in got] == [
        (0.0, 1, False), (2.0, 2, False), (1.0, 2, True), (2.0, 3, True)]
    assert got[-1]["diagnostics"]["late_fused"] == 1
    # More than the lag behind the vehicle's last sample: refused, nothing published.
    client.publish_vectors(vehicle, 0.2, s.vectors(0.2))
    client.publish_gyro_batch(vehicle, gyro[26:])
    client.publish_vectors(vehicle, 6.0, s.vectors(6.0))
    got = estimates.wait_for(lambda i: len(i) >= 5, 10, "the estimate at 6 s")
    client.health()
    for sub in subs:
        sub.undeclare()
    assert [(e["t"], e["seq"]) for e in got[4:]] == [(6.0, 4)]
    assert [r["code"] for r in rejected.snapshot()] == ["out_of_order"]


def test_a_gyro_gap_is_flagged_and_widens_the_covariance(client):
    vehicle = "to-gap"
    s = Scenario(seed=53, duration_s=20.0)
    estimates = Collector()
    sub = subscribe_synced(client, client.subscribe_estimates, estimates, vehicle=vehicle)
    for ch in s.chunks()[:3]:  # gyro at 10 Hz and sets at 0, 1, 2 s
        client.publish_gyro_batch(vehicle, ch.gyro)
        client.publish_vectors(vehicle, ch.t, ch.obs)
    estimates.wait_for(lambda i: len(i) >= 3, 10, "three estimates")
    before = estimates.snapshot()[-1]
    # No gyro from 2 s to 12 s; a set at 12 s: held a window's wall time, then used.
    client.publish_vectors(vehicle, 12.0, s.vectors(12.0))
    after = estimates.wait_for(lambda i: len(i) >= 4, 10, "the estimate after the gap")[-1]
    sub.undeclare()
    d = after["diagnostics"]
    assert d["gyro_gaps"] == 1, d
    assert abs(d["gyro_gap_s"] - 10.0) < 1e-6, d
    assert before["diagnostics"]["gyro_gaps"] == 0 and "gyro_gap_s" not in before["diagnostics"]


def test_a_wildcard_vehicle_chunk_is_refused_on_the_service_key_only(client):
    everyone, service = Collector(), Collector()
    subs = [
        subscribe_synced(client, client.subscribe_rejections, everyone, vehicle="*"),
        subscribe_synced(client, client._subscribe, f"{PREFIX}/@/rejected", service),
    ]
    h0 = client.health()["rejected"].get("invalid_vehicle_id", 0)
    client.session.put(f"{PREFIX}/*/gyro", json.dumps({"t": 1.0, "omega": [0, 0, 0]}))
    service.wait_for(lambda i: len(i) >= 1, 10, "the rejection on P/@/rejected")
    wait_until(lambda: client.health()["rejected"].get("invalid_vehicle_id", 0) == h0 + 1, 10, "the count")
    for sub in subs:
        sub.undeclare()
    assert service.snapshot()[0]["code"] == "invalid_vehicle_id"
    assert service.snapshot()[0]["key"] == f"{PREFIX}/*/gyro"
    assert everyone.snapshot() == [], "no vehicle's rejection subscribers hear it"
