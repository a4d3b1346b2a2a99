"""Several vehicles with different filters, fed concurrently with simulated star-tracker data."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from conftest import Collector, subscribe_synced, validate
from sim import Scenario, angle_error_deg, axis_errors_rad

VEHICLES = {"v-mekf": "mekf", "v-usque": "usque", "v-qpf": "qpf"}
#: Vector sets a publisher may be ahead of the estimates it has received (flow control).
WINDOW = 5


def test_concurrent_vehicles_track_truth_within_3_sigma(service, client, new_client):
    scenarios = {v: Scenario(seed=100 + i, duration_s=60.0) for i, v in enumerate(VEHICLES)}
    streams = {v: s.chunks() for v, s in scenarios.items()}

    estimates = Collector()
    sub = subscribe_synced(client, client.subscribe_estimates, estimates)
    errors: list[str] = []

    def count(vehicle: str) -> int:
        return len([e for e in estimates.snapshot() if e["vehicle"] == vehicle])

    def publisher(vehicle: str):
        try:
            c = new_client()  # one session per vehicle
            for k, chunk in enumerate(streams[vehicle]):
                # As fast as the service takes it: at most WINDOW sets ahead of the estimates.
                deadline = time.monotonic() + 30
                while count(vehicle) < k - WINDOW:
                    if time.monotonic() > deadline:
                        raise TimeoutError(f"{vehicle}: no estimate for set {k - WINDOW} within 30 s")
                    time.sleep(0.002)
                c.publish_gyro_batch(vehicle, chunk.gyro)
                c.publish_vectors(vehicle, chunk.t, chunk.obs)
        except Exception as e:  # reported by the main thread
            errors.append(f"{vehicle}: {e!r}")

    t0 = time.monotonic()
    threads = [threading.Thread(target=publisher, args=(v,), name=v) for v in VEHICLES]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=90)
    assert not any(t.is_alive() for t in threads), "a publisher thread hung"
    assert not errors, errors

    n_sets = {v: len(streams[v]) for v in VEHICLES}
    estimates.wait_for(
        lambda items: all(count(v) >= n_sets[v] for v in VEHICLES),
        timeout=30,
        what=f"all estimates ({n_sets})",
    )
    wall = time.monotonic() - t0
    sub.undeclare()

    report = []
    for vehicle, kind in VEHICLES.items():
        mine = [e for e in estimates.snapshot() if e["vehicle"] == vehicle]
        assert [e["seq"] for e in mine] == list(range(1, n_sets[vehicle] + 1)), f"{vehicle}: seq"
        assert {e["filter"] for e in mine} == {kind}
        last = mine[-1]
        validate("estimate", last)
        row = next(r for r in client.vehicles() if r["vehicle"] == vehicle)
        n_in = n_sets[vehicle] + sum(len(c.gyro) for c in streams[vehicle])
        assert (row["received"], row["processed"], row["rejected"]) == (n_in, n_in, 0), row
        assert last["t"] == pytest.approx(60.0), f"{vehicle}: last estimate at t = {last['t']}"

        # The latest estimate against the truth at its time, per body axis.
        truth = scenarios[vehicle].truth(last["t"])
        err = axis_errors_rad(truth, last["q"])
        sigma = np.radians(last["sigma_deg"])
        # The whole run after the first 5 s: how often each axis was within 3σ (consistency).
        within = []
        for e in mine:
            if e["t"] >= 5.0:
                ea = axis_errors_rad(scenarios[vehicle].truth(e["t"]), e["q"])
                within.extend(np.abs(ea) <= 3 * np.radians(e["sigma_deg"]))
        frac = float(np.mean(within))
        report.append(
            f"{vehicle} ({kind}): error {np.degrees(err) * 3600} arcsec, 1σ {np.degrees(sigma) * 3600} arcsec, "
            f"angle {angle_error_deg(truth, last['q']) * 3600:.2f} arcsec, within 3σ over the run {frac:.3f}"
        )
        # Also what the queryables say: the same latest estimate.
        state = client.get_state(vehicle)
        assert state["seq"] == last["seq"] and state["q"] == last["q"], f"{vehicle}: state != last estimate"
        att = client.get_attitude(vehicle)
        assert att == {"vehicle": vehicle, "t": last["t"], "q": last["q"], "sigma_deg": last["sigma_deg"]}
        assert np.all(np.abs(err) <= 3 * sigma), (
            f"{vehicle} ({kind}): latest estimate outside 3σ per axis: "
            f"|error| {np.abs(err)} rad > 3σ {3 * sigma} rad\n" + "\n".join(report)
        )
        assert frac >= 0.9, f"{vehicle} ({kind}): only {frac:.3f} of the axis errors within 3σ\n" + "\n".join(report)
    print(f"\n{sum(n_sets.values())} vector sets and {sum(len(c.gyro) for s in streams.values() for c in s)} "
          f"gyro samples in {wall:.2f} s\n" + "\n".join(report))
