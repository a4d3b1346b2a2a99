"""The sparse-grid quadrature filter through the service: vehicles reset to `sghqf` (fiducial, level) track a
simulated spacecraft, and their published covariance is consistent with the truth.

`RUNS` = 40 vehicles `sg-<i>` of the shared service (configured with another filter) are each reset to
`sghqf:average` at level 3 with an attitude 1° off the truth and σ = 2°, at t = 0, then fed a simulated
star-tracker run (`Scenario(seed=400 + i)`, 30 s: gyro at 10 Hz, three stars at 1 Hz). As in test_accuracy
(which explains the bound), one attitude NEES per run from the final estimate; the mean of 40 lies in
`χ²₁₂₀(0.0005, 0.9995)/40 = [1.887, 4.440]` for a consistent filter, and the same estimates with a covariance
1.5× off in σ must fall outside it. A vehicle reset to `sghqf:propagated` at level 2 tracks the same way.

Measured: ANEES 2.937 (the figure repeats: the service is deterministic); the level-2 vehicle ends 0.0027° off with
σ ≈ 0.0016° per axis.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from attitude_client import ServiceError
from conftest import Collector, subscribe_synced, validate
from sim import Scenario, angle_error_deg, attitude_nees, to_wire

RUNS = 40
DURATION_S = 30.0
WINDOW = 5
ANEES_BOUNDS = tuple(chi2.ppf([0.0005, 0.9995], 3 * RUNS) / RUNS)


def start(client, vehicle: str, scenario: Scenario, fiducial: str, level: int) -> dict:
    """Resets `vehicle` to the SGHQF, 1° off the truth at t = 0, and checks the reply."""
    off = Rotation.from_rotvec(np.radians(1.0) * np.array([1.0, -1.0, 1.0]) / np.sqrt(3))
    q = to_wire(scenario.truth(0.0) * off)
    reply = client.reset(vehicle, filter="sghqf", fiducial=fiducial, level=level, q=q, sigma_deg=2.0, t=0.0)
    validate("reset-reply", reply)
    assert (reply["state"], reply["filter"], reply["fiducial"], reply["level"]) == (
        "tracking", "sghqf", fiducial, level), reply
    assert "particles" not in reply
    assert reply["estimate"]["diagnostics"]["level"] == level
    return reply


def feed(client, estimates: Collector, vehicle: str, scenario: Scenario, first_seq: int) -> list:
    """The scenario's chunks after the reset's estimate (the set at t = 0 included), with flow control; returns
    the vehicle's estimates."""
    chunks = scenario.chunks()
    for k, chunk in enumerate(chunks):
        deadline = time.monotonic() + 30
        while len(estimates.where(vehicle=vehicle)) < k - WINDOW:
            assert time.monotonic() < deadline, f"{vehicle}: no estimate for set {k - WINDOW} within 30 s"
            time.sleep(0.002)
        client.publish_gyro_batch(vehicle, chunk.gyro)
        client.publish_vectors(vehicle, chunk.t, chunk.obs)
    # (The reset's own estimate is published too: it comes first.)
    got = estimates.wait_for(lambda e: len([m for m in e if m["vehicle"] == vehicle]) > len(chunks), 30,
                             f"{vehicle}: every estimate")
    mine = [m for m in got if m["vehicle"] == vehicle]
    assert [m["seq"] for m in mine] == list(range(first_seq, first_seq + 1 + len(chunks)))
    return mine[1:]


def test_vehicles_reset_to_the_sghqf_track_a_spacecraft_consistently(client):
    assert ANEES_BOUNDS == pytest.approx((1.887, 4.440), abs=1e-3)
    estimates = Collector()
    sub = subscribe_synced(client, client.subscribe_estimates, estimates)
    nees = []
    for i in range(RUNS):
        vehicle = f"sg-{i}"
        scenario = Scenario(seed=400 + i, duration_s=DURATION_S)
        reply = start(client, vehicle, scenario, "average", 3)
        mine = feed(client, estimates, vehicle, scenario, reply["estimate"]["seq"])
        last = mine[-1]
        if i == 0:
            validate("estimate", last)
        d = last["diagnostics"]
        assert (last["filter"], last["fiducial"], d["level"], d["fiducial_fallbacks"]) == ("sghqf", "average", 3, 0)
        assert last["t"] == pytest.approx(DURATION_S)
        nees.append(attitude_nees(scenario.truth(last["t"]), last))
    # Level 2 with the propagated fiducial.
    scenario = Scenario(seed=399, duration_s=DURATION_S)
    reply = start(client, "sg-l2", scenario, "propagated", 2)
    last = feed(client, estimates, "sg-l2", scenario, reply["estimate"]["seq"])[-1]
    sub.undeclare()
    assert (last["filter"], last["fiducial"], last["diagnostics"]["level"]) == ("sghqf", "propagated", 2)
    assert "fiducial_fallbacks" not in last["diagnostics"]
    error = angle_error_deg(scenario.truth(last["t"]), last["q"])
    assert error < 5 * max(last["sigma_deg"]), (error, last["sigma_deg"])

    anees = float(np.mean(nees))
    lo, hi = ANEES_BOUNDS
    print(f"\nsghqf:average L = 3: ANEES {anees:.3f} over {RUNS} runs (bound [{lo:.3f}, {hi:.3f}]); "
          f"sghqf:propagated L = 2: final error {error:.2e}°, σ {np.round(last['sigma_deg'], 6).tolist()}°")
    assert lo <= anees <= hi, anees
    for scale in (2.25, 1 / 2.25):
        assert not lo <= anees * scale <= hi, f"the covariance scaled by 1/{scale} would pass"


def test_a_level_outside_two_to_four_is_refused_and_changes_nothing(client):
    before = client.reset("sg-bad", filter="sghqf", level=4, q=(1, 0, 0, 0), sigma_deg=1.0, t=5.0)
    assert before["level"] == 4
    for level in (1, 5):
        with pytest.raises(ServiceError) as e:
            client.reset("sg-bad", filter="sghqf", level=level)
        assert (e.value.code, e.value.message) == ("bad_request", f"level must be in 2..=4, got {level}"), e.value
    state = client.get_state("sg-bad")
    assert (state["filter"], state["diagnostics"]["level"], state["seq"]) == ("sghqf", 4, before["estimate"]["seq"])
