"""`attitude-service simulate` against the service: the truth it publishes and the estimates agree with the
Python convention of the tests (errors within 3σ per body axis)."""

from __future__ import annotations

import subprocess
import time

import numpy as np

from conftest import BIN, Collector, subscribe_synced, validate
from sim import axis_errors_rad, to_rotation


def test_simulated_fleet_is_tracked_within_3_sigma(service, client):
    truths, estimates, rejections = Collector(), Collector(), Collector()
    subs = [
        subscribe_synced(client, client.subscribe_truth, truths, vehicle="simsc$*"),
        subscribe_synced(client, client.subscribe_estimates, estimates, vehicle="simsc$*"),
        subscribe_synced(client, client.subscribe_rejections, rejections, vehicle="simsc$*"),
    ]
    cmd = [
        str(BIN), "simulate", "--scenario", "star-tracker", "--duration", "120", "--speed", "0",
        "--vehicles", "2", "--vehicle-prefix", "simsc", "--filters", "mekf,usque:average",
        "--prefix", service.prefix, "--connect", service.endpoint,
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    n = 2 * 120
    estimates.wait_for(lambda i: len([e for e in i if e["t"] > 0]) >= n, 20, f"{n} estimates")
    time.sleep(0.2)
    for s in subs:
        s.undeclare()
    assert rejections.snapshot() == []
    truth = {(m["vehicle"], m["t"]): m for m in truths.snapshot()}
    assert len(truth) == n
    validate("truth", next(iter(truth.values())))
    for vehicle in ("simsc1", "simsc2"):
        mine = [e for e in estimates.snapshot() if e["vehicle"] == vehicle and (vehicle, e["t"]) in truth]
        assert len(mine) >= 100
        within = []
        for e in mine:
            err = axis_errors_rad(to_rotation(truth[(vehicle, e["t"])]["q"]), e["q"])
            within.extend(np.abs(err) <= 3 * np.radians(e["sigma_deg"]))
        last = mine[-1]
        err = axis_errors_rad(to_rotation(truth[(vehicle, last["t"])]["q"]), last["q"])
        assert np.all(np.abs(err) <= 3 * np.radians(last["sigma_deg"])), (vehicle, err, last["sigma_deg"])
        assert np.mean(within) >= 0.95, (vehicle, np.mean(within))
