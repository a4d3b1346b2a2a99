"""Inputs: health counters grow; every malformed put is refused on P/V/rejected with its code and counted."""

from __future__ import annotations

import json
import signal

import pytest

from conftest import PREFIX, VEHICLES, Collector, ServiceProcess, subscribe_synced, validate, wait_until
from sim import Scenario

GOOD_OBS = [{"body": [1, 0, 0], "ref": [1, 0, 0], "sigma": 1e-4}, {"body": [0, 1, 0], "ref": [0, 1, 0], "sigma": 1e-4}]


def vectors(t, **change):
    o = dict(GOOD_OBS[0], **change)
    return json.dumps({"t": t, "obs": [o, GOOD_OBS[1]]})


def test_health_counters_grow(client):
    h0 = client.health()
    s = Scenario(seed=21, duration_s=5.0)
    chunks = s.chunks()
    n_gyro = sum(len(c.gyro) for c in chunks)
    for c in chunks:
        client.publish_gyro_batch("h-1", c.gyro)
        client.publish_vectors("h-1", c.t, c.obs)
    n = n_gyro + len(chunks)

    def grown():
        h = client.health()
        return h["estimates_published"] >= h0["estimates_published"] + len(chunks) and h["processed"] >= h0["processed"] + n

    wait_until(grown, 10, "the counters to grow")
    h1 = client.health()
    validate("health", h1)
    assert h1["received"] >= h0["received"] + n
    assert h1["processed"] >= h0["processed"] + n
    assert h1["estimates_published"] >= h0["estimates_published"] + len(chunks)
    assert h1["processed"] <= h1["received"]
    assert h1["uptime_s"] > h0["uptime_s"]
    assert h1["vehicles"] >= 1
    row = next(r for r in client.vehicles() if r["vehicle"] == "h-1")
    assert (row["received"], row["processed"], row["estimates"], row["rejected"]) == (n, n, len(chunks), 0), row



def test_health_says_whether_anyone_listens_to_the_estimates():
    """`listened`: with no subscriber the service serialises and puts no estimate (queries still answer the
    last); a subscriber of another session makes it true, and then the next estimate reaches it; gone, false
    again."""
    svc = ServiceProcess({"vehicles": VEHICLES})
    c = svc.client()
    try:
        svc.wait_ready(c)
        h = c.health()
        validate("health", h)
        assert h["listened"] is False, h
        c.publish_gyro("l-1", 0.5, [0.0, 0.0, 0.0])
        c.publish_vectors("l-1", 1.0, GOOD_OBS)
        wait_until(lambda: c.health()["estimates_published"] == 1, 10, "the first estimate")
        assert c.get_state("l-1")["t"] == 1.0  # made and kept for the queries
        estimates = Collector()
        sub = c.subscribe_estimates(estimates)
        wait_until(lambda: c.health()["listened"], 10, "listened after subscribing")
        c.publish_vectors("l-1", 2.0, GOOD_OBS)
        wait_until(lambda: [m["t"] for m in estimates.snapshot()] == [2.0], 10, "the estimate at t = 2 alone")
        sub.undeclare()
        wait_until(lambda: not c.health()["listened"], 10, "not listened once the subscriber is gone")
    finally:
        c.close()
        svc.stop(signal.SIGTERM, timeout=10.0)

# (leaf, payload, code): each must be refused with `code` on P/V/rejected, with the input's key.
MALFORMED = [
    ("gyro", b"{not json", "invalid_json"),
    ("gyro", b"\xff\xfe", "invalid_utf8"),
    ("gyro", b'{"t": 100.0, "omega": [0, 0, NaN]}', "invalid_json"),
    ("gyro", b'{"t": null, "omega": [0, 0, 0]}', "non_finite"),
    ("gyro", b'{"t": 100.0, "omega": [0, null, 0]}', "non_finite"),
    ("gyro", b'{"t": 100.0, "omega": [0, 0]}', "bad_request"),
    ("gyro", b'{"t": 100.0, "omega": [0, 0, 0], "extra": 1}', "bad_request"),
    ("gyro", b'{"t": "now", "omega": [0, 0, 0]}', "bad_request"),
    ("gyro", b"[]", "bad_request"),
    ("gyro", b'[{"t": 100.0, "omega": [0, 0, 0]}, {"t": 100.1, "omega": [0, 0]}]', "bad_request"),
    ("vectors", vectors(100.0, body=[0, 0, 0]).encode(), "zero_vector"),
    ("vectors", vectors(100.0, ref=[1e-12, 0, 0]).encode(), "zero_vector"),
    ("vectors", vectors(100.0, sigma=0).encode(), "bad_sigma"),
    ("vectors", vectors(100.0, sigma=-1e-4).encode(), "bad_sigma"),
    ("vectors", vectors(100.0, body=[None, 0, 1]).encode(), "non_finite"),
    ("vectors", vectors(100.0, sigma=None).encode(), "non_finite"),
    ("vectors", vectors(100.0, sensor="").encode(), "bad_request"),
    ("vectors", b'{"t": 100.0, "obs": []}', "bad_request"),
    ("vectors", json.dumps({"t": 100.0, "obs": GOOD_OBS * 33}).encode(), "batch_too_large"),
    ("vectors", vectors(1.0).encode(), "out_of_order"),  # the vehicle is at t = 10
]


@pytest.mark.parametrize("leaf, payload, code", MALFORMED, ids=[f"{l}-{c}-{i}" for i, (l, _, c) in enumerate(MALFORMED)])
def test_malformed_input_is_rejected_and_counted(client, leaf, payload, code):
    vehicle = "bad-1"
    # A tracking vehicle at t = 10.
    client.reset(vehicle, q={"w": 1, "x": 0, "y": 0, "z": 0}, sigma_deg=0.1, t=10.0)
    before = client.health()["rejected"].get(code, 0)
    row0 = next(r for r in client.vehicles() if r["vehicle"] == vehicle)

    rejected = Collector()
    sub = subscribe_synced(client, client.subscribe_rejections, rejected)
    client.put_raw(vehicle, leaf, payload)
    got = rejected.wait_for(lambda i: len(i) >= 1, 10, f"a rejection ({code})")
    # Nothing else arrives for this one input.
    client.health()
    sub.undeclare()
    got = rejected.snapshot()
    assert len(got) == 1, got
    msg = got[0]
    validate("error", msg)
    assert msg["code"] == code, msg
    assert msg["key"] == f"{PREFIX}/{vehicle}/{leaf}"
    assert msg["message"]

    wait_until(lambda: client.health()["rejected"].get(code, 0) == before + 1, 5, f"rejected[{code}] + 1")
    row1 = next(r for r in client.vehicles() if r["vehicle"] == vehicle)
    assert row1["rejected"] == row0["rejected"] + 1
    assert row1["processed"] == row0["processed"], "a refused input is not processed"


def test_a_valid_batch_item_does_not_save_an_invalid_batch(client):
    """A batch is refused as a whole when one item is invalid (the message names the item)."""
    vehicle = "bad-batch"
    rejected = Collector()
    sub = subscribe_synced(client, client.subscribe_rejections, rejected, vehicle=vehicle)
    client.put_raw(vehicle, "gyro", b'[{"t": 1, "omega": [0, 0, 0]}, {"t": 2, "omega": [0, 0, null]}]')
    got = rejected.wait_for(lambda i: len(i) >= 1, 10, "a rejection")
    sub.undeclare()
    assert got[0]["code"] == "non_finite"
    assert "1" in got[0]["message"]
    # Nothing was used; the vehicle was not even created (it exists from its first valid measurement).
    assert all(r["vehicle"] != vehicle for r in client.vehicles())


def test_invalid_vehicle_id_is_rejected(client):
    rejected = Collector()
    sub = subscribe_synced(client, client.subscribe_rejections, rejected)
    before = client.health()["rejected"].get("invalid_vehicle_id", 0)
    client.put_raw("bad.id", "gyro", b'{"t": 1, "omega": [0, 0, 0]}')
    got = rejected.wait_for(lambda i: len(i) >= 1, 10, "a rejection")
    sub.undeclare()
    assert got[0]["code"] == "invalid_vehicle_id" and got[0]["key"] == f"{PREFIX}/bad.id/gyro", got
    wait_until(lambda: client.health()["rejected"].get("invalid_vehicle_id", 0) == before + 1, 5, "the count")
    assert all(r["vehicle"] != "bad.id" for r in client.vehicles())


def test_a_single_vector_cannot_start_a_vehicle(client):
    rejected = Collector()
    sub = subscribe_synced(client, client.subscribe_rejections, rejected, vehicle="one-vec")
    client.publish_vectors("one-vec", 1.0, [([1, 0, 0], [0, 0, 1], 1e-4)])
    got = rejected.wait_for(lambda i: len(i) >= 1, 10, "a rejection")
    sub.undeclare()
    assert got[0]["code"] == "not_initialized", got


def test_equal_times_are_accepted(client):
    vehicle = "eq-t"
    estimates = Collector()
    rejected = Collector()
    subs = [
        subscribe_synced(client, client.subscribe_estimates, estimates, vehicle=vehicle),
        subscribe_synced(client, client.subscribe_rejections, rejected, vehicle=vehicle),
    ]
    s = Scenario(seed=31)
    client.publish_gyro(vehicle, 1.0, [0, 0, 0.01])
    client.publish_vectors(vehicle, 1.0, s.vectors(1.0))
    # Another set at the same instant (new noise: an identical set, like a second gyro sample at the
    # same time, would be a duplicate).
    client.publish_vectors(vehicle, 1.0, s.vectors(1.0))
    estimates.wait_for(lambda i: len(i) >= 2, 10, "two estimates")
    client.health()
    for sub in subs:
        sub.undeclare()
    assert rejected.snapshot() == []
    assert [e["t"] for e in estimates.snapshot()] == [1.0, 1.0]


def test_estimate_diagnostics_count_rejected_inputs(client):
    """proto/README.md (Errors): refused inputs are also counted in the vehicle's `diagnostics.rejected`."""
    vehicle = "diag-rej"
    s = Scenario(seed=41)
    estimates = Collector()
    sub = subscribe_synced(client, client.subscribe_estimates, estimates, vehicle=vehicle)
    client.publish_vectors(vehicle, 1.0, s.vectors(1.0))
    # (Once the set at 1 s is processed: until then the reorder window would still take 0.5 s.)
    estimates.wait_for(lambda i: len(i) >= 1, 10, "the estimate at t = 1")
    client.put_raw(vehicle, "vectors", vectors(2.0, sigma=0).encode())
    # Out of order: older than the last processed set by more than time.max_lag_s (2 s; a later one is fused).
    client.put_raw(vehicle, "vectors", vectors(-1.5).encode())
    client.publish_vectors(vehicle, 3.0, s.vectors(3.0))
    got = estimates.wait_for(lambda i: any(e["t"] == 3.0 for e in i), 10, "the estimate at t = 3")
    sub.undeclare()
    row = next(r for r in client.vehicles() if r["vehicle"] == vehicle)
    assert row["rejected"] == 2
    diag = next(e for e in got if e["t"] == 3.0)["diagnostics"]
    assert diag.get("rejected") == {"bad_sigma": 1, "out_of_order": 1}, (
        f"RUST BUG: diagnostics.rejected is {diag.get('rejected')!r} after two refused inputs "
        "(P/@/vehicles counts them: rejected = 2); proto/README.md and estimate.schema.json say it holds the "
        "vehicle's refused inputs by code (EstimateMsg::from_domain always sets an empty map)"
    )
