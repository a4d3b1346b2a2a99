"""The Python client itself: input forms, local validation, clean interpreter exit."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from attitude_client import AttitudeClient, ServiceError, attitude_error_deg
from conftest import ROOT, Collector, subscribe_synced, wait_until


def test_observation_forms_and_numpy_inputs(client):
    """Observations as dicts or tuples (with or without a sensor name), vectors as lists or numpy arrays."""
    vehicle = "c-forms"
    estimates = Collector()
    sub = subscribe_synced(client, client.subscribe_estimates, estimates, vehicle=vehicle)
    client.publish_gyro(vehicle, 0.0, np.array([0.0, 0.0, 0.0]))
    client.publish_vectors(
        vehicle,
        np.float64(0.0),
        [
            {"body": [1, 0, 0], "ref": [1, 0, 0], "sigma": 1e-4, "sensor": "st1"},
            ([0, 1, 0], [0, 1, 0], 1e-4),
            (np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]), np.float32(1e-4), "st2"),
        ],
    )
    # Two different sets at the same time (an identical one would be a duplicate).
    client.publish_vectors_batch(
        vehicle,
        [
            (1.0, [([1, 0, 0], [1, 0, 0], 1e-4), ([0, 1, 0], [0, 1, 0], 1e-4)]),
            (1.0, [([1, 0, 0], [1, 0, 0], 2e-4), ([0, 1, 0], [0, 1, 0], 2e-4)]),
        ],
    )
    got = estimates.wait_for(lambda i: len(i) >= 3, 10, "three estimates")
    sub.undeclare()
    assert [e["t"] for e in got] == [0.0, 1.0, 1.0]
    assert attitude_error_deg(got[-1]["q"], {"w": 1, "x": 0, "y": 0, "z": 0}) < 0.01


def test_imu_forms(client):
    """Raw IMU samples one by one and in batches, with and without a magnetometer, as lists or numpy arrays: after
    the pipeline's alignment (service.imu.init.duration_s, 0.1 s) one estimate per sample. Level and facing
    magnetic north (specific force up, field north and down): the identity."""
    vehicle = "c-imu"
    estimates = Collector()
    sub = subscribe_synced(client, client.subscribe_estimates, estimates, vehicle=vehicle)
    acc, mag = np.array([0.0, 0.0, 9.81]), [0.0, 20.0, -40.0]
    client.publish_imu(vehicle, 0.0, np.zeros(3), acc, mag)
    client.publish_imu_batch(vehicle, [(0.01 * k, [0, 0, 0], acc, mag) for k in range(1, 20)])
    client.publish_imu_batch(vehicle, [(0.2 + 0.01 * k, (0.0, 0.0, 0.0), acc.tolist()) for k in range(10)])
    client.publish_imu(vehicle, 0.3, [0, 0, 0], acc, mag=None)
    got = estimates.wait_for(lambda i: len(i) >= 21, 10, "21 estimates")
    sub.undeclare()
    assert [round(e["t"], 6) for e in got] == [round(0.1 + 0.01 * k, 6) for k in range(21)]
    assert attitude_error_deg(got[-1]["q"], {"w": 1, "x": 0, "y": 0, "z": 0}) < 0.5


def test_local_validation(client):
    with pytest.raises(ValueError):
        client.publish_gyro("c-bad", math.nan, [0, 0, 0])
    with pytest.raises(ValueError):
        client.publish_gyro("c-bad", 1.0, [0, 0])
    with pytest.raises(ValueError):
        client.publish_gyro_batch("c-bad", [])
    with pytest.raises(ValueError):
        client.publish_imu("c-bad", 1.0, [0, 0, 0], [0, 9.81])
    with pytest.raises(ValueError):
        client.publish_imu_batch("c-bad", [])
    with pytest.raises(ValueError):
        client.get_attitude("*")
    with pytest.raises(ValueError):
        client.get_all("reset")
    # Nothing was sent: the vehicle does not exist.
    with pytest.raises(ServiceError) as info:
        client.get_attitude("c-bad")
    assert info.value.code == "unknown_vehicle"


def test_reset_accepts_a_sequence_quaternion(client):
    """``q`` as ``(w, x, y, z)``, scalar first; the reply normalises ``w >= 0``."""
    reply = client.reset("c-seq", filter="mekf", q=(-0.5, 0.5, -0.5, 0.5), sigma_deg=1, t=0)
    q = reply["estimate"]["q"]
    assert [q[k] for k in "wxyz"] == pytest.approx([0.5, -0.5, 0.5, -0.5], abs=1e-12)


def test_script_that_forgets_close_still_exits(service):
    """zenoh runs callbacks on a non-daemon thread; the client closes itself at interpreter exit."""
    code = textwrap.dedent(
        f"""
        from attitude_client import AttitudeClient
        c = AttitudeClient({service.endpoint!r}, prefix={service.prefix!r})
        c.wait_for_service()
        sub = c.subscribe_estimates(lambda e: None)
        print("ok")
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=20)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_context_manager_closes_the_session(service):
    with service.client() as c:
        c.wait_for_service()
        assert not c.session.is_closed()
    assert c.session.is_closed()


def test_docstring_example_runs(service):
    """The example of the client module's docstring, against the test service."""
    import attitude_client.client

    doc = attitude_client.client.__doc__
    block = doc[doc.index("    from attitude_client") : doc.index("\n\n", doc.index("    from attitude_client"))]
    example = textwrap.dedent(block).replace(
        'AttitudeClient("tcp/127.0.0.1:7447")',
        f"AttitudeClient({service.endpoint!r}, prefix={service.prefix!r})",
    )
    assert len(example.strip().splitlines()) == 5
    code = example
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    assert "'vehicle': 'sc1', 't': 0.0, 'q': {'w': 1.0, 'x': 0.0, 'y': 0.0, 'z': 0.0}" in out.stdout, out.stdout
