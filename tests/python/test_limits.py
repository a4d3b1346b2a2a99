"""The configured limits, on a service of their own: each refusal has its code."""

from __future__ import annotations

import json

import pytest

from conftest import Collector, ServiceProcess, subscribe_synced, validate

LIMITS = {"max_vehicles": 3, "queue_per_vehicle": 16, "max_payload_bytes": 4000, "max_batch": 20, "max_observations": 4}


@pytest.fixture(scope="module")
def limited():
    svc = ServiceProcess({"filter": {"kind": "mekf"}, "limits": LIMITS}, prefix="limits")
    c = svc.client()
    svc.wait_ready(c)
    yield svc, c
    c.close()
    code, took = svc.stop()
    assert code == 0, svc.log()[-4000:]


def refused(c, vehicle, leaf, payload) -> dict:
    rejected = Collector()
    sub = subscribe_synced(c, c.subscribe_rejections, rejected)
    c.put_raw(vehicle, leaf, payload)
    got = rejected.wait_for(lambda i: len(i) >= 1, 10, "a rejection")
    sub.undeclare()
    validate("error", got[0])
    return got[0]


def gyro_batch(n, t0=0.0):
    return json.dumps([{"t": t0 + 0.1 * i, "omega": [0, 0, 0]} for i in range(n)])


def test_limits(limited):
    svc, c = limited
    assert c.vehicles() == [], "no vehicle before the first measurement"
    assert refused(c, "a", "gyro", gyro_batch(21))["code"] == "batch_too_large"
    obs = [{"body": [1, 0, 0], "ref": [1, 0, 0], "sigma": 1e-4}] * 5
    assert refused(c, "a", "vectors", json.dumps({"t": 0, "obs": obs}))["code"] == "batch_too_large"
    big = json.dumps({"t": 0, "omega": [0, 0, 0], "pad": "x" * 5000})
    assert refused(c, "a", "gyro", big)["code"] == "payload_too_large"
    # A batch larger than the vehicle's queue cannot be queued.
    c.publish_gyro("a", 0.0, [0, 0, 0])
    assert refused(c, "a", "gyro", gyro_batch(17, t0=1.0))["code"] == "queue_full"
    for v in ("b", "c"):
        c.publish_gyro(v, 0.0, [0, 0, 0])
    assert refused(c, "d", "gyro", json.dumps({"t": 0, "omega": [0, 0, 0]}))["code"] == "too_many_vehicles"
    replies = c.query("e/reset", payload="{}")
    assert not replies[0][1] and json.loads(replies[0][2])["code"] == "too_many_vehicles"
    assert sorted(r["vehicle"] for r in c.vehicles()) == ["a", "b", "c"]
    h = c.health()
    for code in ("batch_too_large", "payload_too_large", "queue_full", "too_many_vehicles"):
        assert h["rejected"].get(code, 0) >= 1, (code, h)
