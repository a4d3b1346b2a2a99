"""The Python client as a package (clients/python): numpy estimates checked against SciPy, IMU samples from numpy
arrays, estimates as an iterator and an async iterator that never hold up the service, the version, the wheel, and
the README's example run from a fresh venv with `pip install ./clients/python[scipy]`, as a new user would."""

from __future__ import annotations

import asyncio
import math
import pathlib
import re
import signal
import subprocess
import sys
import textwrap
import tomllib
import zipfile

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import attitude_client
from attitude_client import AttitudeClient, Estimate, attitude_matrix
from conftest import ROOT, free_port, wait_until

PACKAGE = ROOT / "clients" / "python"


def test_the_version_is_the_services():
    cargo = tomllib.loads((ROOT / "Cargo.toml").read_text())["package"]["version"]
    project = tomllib.loads((PACKAGE / "pyproject.toml").read_text())["project"]
    assert project["version"] == cargo == attitude_client.__version__
    assert project["name"] == "attitude-client"


def test_the_quaternion_order_and_frame_are_scipys_rotation_body_to_reference(client):
    """A vehicle started from two star-like vectors whose body coordinates SciPy computed from a known rotation
    (``b = R⁻¹ r``, R body → reference): the service's estimate, read as an Estimate, is that rotation."""
    truth = Rotation.from_euler("ZYX", [30.0, -20.0, 10.0], degrees=True)  # body → reference
    refs = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.0, 0.0, 1.0]])
    bodies = truth.inv().apply(refs)
    vehicle = "pkg-frame"
    client.reset(vehicle, filter="mekf")
    client.publish_vectors(vehicle, 1.0, [(b, r, 1e-5) for b, r in zip(bodies, refs)])
    wait_until(lambda: _has_estimate(client, vehicle), 10, "an estimate")
    e = client.estimate(vehicle)
    assert isinstance(e, Estimate) and e.vehicle == vehicle and e.t == 1.0 and e.filter == "mekf"
    assert e.q.shape == (4,) and e.q[0] >= 0 and abs(np.linalg.norm(e.q) - 1) < 1e-12
    assert np.degrees((e.rotation() * truth.inv()).magnitude()) < 1e-3
    # The order: [w, x, y, z] here, [x, y, z, w] for SciPy; the wire's {w, x, y, z} is the same quaternion.
    assert np.allclose(e.q_xyzw, truth.as_quat() * np.sign(truth.as_quat()[3]), atol=1e-7)
    wire = client.get_state(vehicle)["q"]
    assert e.q.tolist() == [wire[k] for k in "wxyz"]
    # A = Rᵀ: b = A r, and the attitude matrix is SciPy's inverse rotation.
    assert np.allclose(e.attitude_matrix(), e.rotation().inv().as_matrix(), atol=1e-12)
    assert np.allclose(e.attitude_matrix() @ refs.T, bodies.T, atol=1e-4)
    assert e.cov.shape == (6, 6) and np.allclose(e.cov, e.cov.T)
    assert np.allclose(np.degrees(np.sqrt(np.diag(e.cov)[:3])), e.sigma_deg, rtol=1e-9)
    assert e.bias.shape == (3,) and e.seq >= 1


def test_attitude_matrix_is_shusters():
    """``A(q) = (w² − ϱᵀϱ) I + 2 ϱϱᵀ − 2 w [ϱ×]`` (proto/README.md), written out independently."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        w, v = q[0], q[1:]
        cross = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        shuster = (w * w - v @ v) * np.eye(3) + 2 * np.outer(v, v) - 2 * w * cross
        assert np.allclose(attitude_matrix(q), shuster, atol=1e-14)
        assert np.allclose(attitude_matrix(q), Rotation.from_quat(np.roll(q, -1)).inv().as_matrix(), atol=1e-12)


def _has_estimate(client: AttitudeClient, vehicle: str) -> bool:
    try:
        client.get_attitude(vehicle, timeout=0.5)
        return True
    except Exception:
        return False


def _processed(client: AttitudeClient, vehicle: str) -> int:
    rows = [r for r in client.vehicles() if r["vehicle"] == vehicle]
    return rows[0]["processed"] if rows else 0


def test_publish_imu_takes_whole_arrays_and_estimates_come_as_an_iterator(client):
    """Two seconds of a level IMU facing magnetic north at 100 Hz, as numpy arrays (a NaN row of the magnetometer
    leaves the field out of that sample), in batches of 64: every sample processed, one estimate per sample after
    the 0.1 s alignment, each an Estimate of the identity with its covariance."""
    vehicle = "pkg-imu"
    n = 200
    t = 0.01 * np.arange(n)
    gyr = np.zeros((n, 3))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    mag = np.tile([0.0, 20.0, -40.0], (n, 1))
    mag[50] = np.nan
    with client.estimates(vehicle, timeout=5.0) as stream:
        client.health()  # the subscription reached the service before the samples (one link, in order)
        assert client.publish_imu(vehicle, t, gyr, acc, mag, batch=64) == n
        got = []
        for e in stream:
            got.append(e)
            if len(got) == n - 10:
                break
    assert stream.dropped == 0 and stream.malformed == 0
    assert [round(e.t, 6) for e in got] == [round(x, 6) for x in t[10:]]
    last = got[-1]
    assert isinstance(last, Estimate) and last.cov.shape == (6, 6)
    assert attitude_client.attitude_error_deg(last.q, [1, 0, 0, 0]) < 0.5
    wait_until(lambda: _processed(client, vehicle) == n, 10, f"{n} samples processed")


def test_local_validation_of_arrays(client):
    t = np.arange(3) * 0.01
    with pytest.raises(ValueError, match=r"shape \(3, 3\)"):
        client.publish_imu("pkg-bad", t, np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="finite"):
        client.publish_imu("pkg-bad", t, np.full((3, 3), np.nan), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="partly non-finite"):
        client.publish_imu("pkg-bad", t, np.zeros((3, 3)), np.zeros((3, 3)), np.array([[1, np.nan, 0]] * 3))
    with pytest.raises(ValueError, match="shape"):
        client.publish_gyro("pkg-bad", t, np.zeros(3))
    assert not _has_estimate(client, "pkg-bad")


def _spacecraft_sets(k: int) -> tuple[float, list]:
    refs = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    return float(k), [(r, r, 1e-4) for r in refs]


def test_estimates_as_an_async_iterator(client):
    vehicle = "pkg-async"
    client.reset(vehicle, filter="mekf")

    async def follow() -> list[Estimate]:
        got = []
        with client.estimates(vehicle, timeout=5.0) as stream:
            client.health()
            # Published from another thread while the event loop waits in __anext__.
            loop = asyncio.get_running_loop()
            sender = loop.run_in_executor(None, lambda: [client.publish_vectors(vehicle, *_spacecraft_sets(k)) for k in range(1, 6)])
            async for e in stream:
                got.append(e)
                if len(got) == 5:
                    break
            await sender
        return got

    got = asyncio.run(follow())
    assert [e.t for e in got] == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert [e.seq for e in got] == sorted(e.seq for e in got)


def test_a_reader_that_falls_behind_drops_its_oldest_and_never_holds_up_the_service(client):
    """A stream of capacity 4 that is not read while 40 estimates are published: the service publishes all 40 at
    its pace (its estimate count), the stream keeps the newest 4 and counts 36 dropped."""
    vehicle = "pkg-slow"
    client.reset(vehicle, filter="mekf")
    with client.estimates(vehicle, maxsize=4) as stream:
        client.health()
        client.publish_vectors_batch(vehicle, [_spacecraft_sets(k) for k in range(1, 41)])
        wait_until(lambda: stream.dropped + len(stream) == 40, 10, "40 estimates at the stream")
        rows = [r for r in client.vehicles() if r["vehicle"] == vehicle]
        assert rows[0]["estimates"] >= 40
        kept = [stream.get_nowait() for _ in range(4)]
    assert stream.dropped == 36
    assert [e.t for e in kept] == [37.0, 38.0, 39.0, 40.0]


def test_messages_follow_several_leaves_in_one_stream(client):
    """`client.messages(("estimate", "rejected"))`: one buffer, arrival order, the concrete key with each message
    (what attitude-view reads): an estimate, then the rejection of a set that refers to an older time."""
    vehicle = "pkg-msgs"
    client.reset(vehicle, filter="mekf")
    with client.messages(("estimate", "rejected"), vehicles=vehicle, timeout=5.0) as stream:
        assert stream.keys == (f"{client.prefix}/{vehicle}/estimate", f"{client.prefix}/{vehicle}/rejected")
        client.health()
        client.publish_vectors(vehicle, *_spacecraft_sets(5))
        first = stream.get(timeout=5.0)
        client.publish_vectors(vehicle, *_spacecraft_sets(2))
        second = stream.get(timeout=5.0)
    assert first[0] == f"{client.prefix}/{vehicle}/estimate" and first[1]["t"] == 5.0
    assert second[0] == f"{client.prefix}/{vehicle}/rejected" and second[1]["code"] == "out_of_order"
    assert stream.dropped == 0 and stream.malformed == 0
    with pytest.raises(ValueError, match="leaf"):
        client.messages(("*",))


def test_the_wheel_is_typed_and_installs_its_scripts(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(PACKAGE)],
        capture_output=True, text=True, timeout=300,
    )
    assert out.returncode == 0, out.stderr
    (wheel,) = tmp_path.glob("attitude_client-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for module in ("__init__", "client", "estimate", "stream", "replay"):
        assert f"attitude_client/{module}.py" in names
    # attitude-view, a package: the model, its sinks and the command line.
    for module in ("__init__", "__main__", "geometry", "schemas", "model", "foxglove_sink", "rerun_sink", "cli"):
        assert f"attitude_client/view/{module}.py" in names
    assert "attitude_client/py.typed" in names
    assert "attitude_client/layouts/demo.json" in names
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    text = zipfile.ZipFile(wheel).read(entry_points).decode()
    assert "attitude-replay = attitude_client.replay:main" in text
    assert "attitude-view = attitude_client.view.cli:main" in text
    metadata = zipfile.ZipFile(wheel).read(next(n for n in names if n.endswith("METADATA"))).decode()
    assert re.search(r"^Requires-Dist: eclipse-zenoh", metadata, re.M)
    assert re.search(r"^Requires-Dist: numpy", metadata, re.M)
    assert re.search(r"^Requires-Dist: scipy.*extra == .scipy.", metadata, re.M)
    assert re.search(r"^Requires-Dist: foxglove-sdk.*extra == .view.", metadata, re.M)
    assert re.search(r"^Requires-Dist: rerun-sdk<0\.42,>=0\.41\.0; .*python_version >= .3\.11.*extra == .view-rerun.",
                     metadata, re.M), metadata


def readme_example() -> str:
    """The README's Python example (the block after "### From Python" that imports the client)."""
    text = (ROOT / "README.md").read_text()
    section = text[text.index("### From Python") :]
    block = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    assert "from attitude_client import AttitudeClient" in block
    return block


@pytest.fixture(scope="module")
def fresh_venv(tmp_path_factory):
    """`python3 -m venv` and `pip install './clients/python[scipy]'` as the README says (packages from PyPI, or
    pip's cache)."""
    venv = tmp_path_factory.mktemp("fresh") / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    out = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "--disable-pip-version-check", f"{PACKAGE}[scipy]"],
        capture_output=True, text=True, timeout=600,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    return venv


def test_the_readme_example_works_from_a_fresh_venv(service, client, fresh_venv, tmp_path):
    """The README's five lines from a fresh venv (`fresh_venv`) against the service, with a vehicle sc1."""
    example = readme_example()
    assert len(example.strip().splitlines()) == 5
    assert "pip install './clients/python[scipy]'" in (ROOT / "README.md").read_text()
    client.reset("sc1", filter="mekf", q=(math.cos(0.25), 0, 0, math.sin(0.25)), sigma_deg=0.5, t=0.0)
    venv = fresh_venv
    py = venv / "bin" / "python"
    code = example.replace(
        'AttitudeClient("tcp/127.0.0.1:7447")', f"AttitudeClient({service.endpoint!r}, prefix={service.prefix!r})"
    )
    run = subprocess.run([str(py), "-c", code], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.strip().splitlines()
    assert len(lines) == 2, run.stdout
    assert "[0.96891242 0.         0.         0.24740396]" in lines[0], lines[0]  # cos 0.25, sin 0.25
    yaw, pitch, roll = (float(x) for x in lines[1].strip("[]").split())
    assert (yaw, pitch, roll) == pytest.approx((math.degrees(0.5), 0.0, 0.0), abs=1e-7)  # printed to 8 decimals
    # The package is what was imported (not the source tree), with its console script.
    where = subprocess.run([str(py), "-c", "import attitude_client; print(attitude_client.__file__)"], capture_output=True, text=True, cwd=tmp_path)
    assert str(venv) in where.stdout
    helped = subprocess.run([str(venv / "bin" / "attitude-replay"), "--help"], capture_output=True, text=True, timeout=60)
    assert helped.returncode == 0 and "--connect" in helped.stdout, helped.stderr


def test_the_view_extra_installs_in_the_fresh_venv(fresh_venv, tmp_path):
    """`pip install './clients/python[view]'` as docs/view.md says (foxglove-sdk from PyPI, or pip's cache), into the
    README's fresh venv: the installed attitude-view has its layout file, and its Foxglove server answers a client
    (here with no service: it says so and serves anyway)."""
    from foxglove_ws import FoxgloveClient

    from attitude_client import view

    assert "pip install './clients/python[view]'" in (ROOT / "docs" / "view.md").read_text()
    py = fresh_venv / "bin" / "python"
    out = subprocess.run(
        [str(py), "-m", "pip", "install", "-q", "--disable-pip-version-check", f"{PACKAGE}[view]"],
        capture_output=True, text=True, timeout=600,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    script = fresh_venv / "bin" / "attitude-view"
    layout = subprocess.run([str(script), "--write-layout", "-"], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert layout.returncode == 0, layout.stderr
    assert layout.stdout == view.layout_json()
    shipped = subprocess.run(
        [str(py), "-c", "from importlib import resources; import attitude_client; print(attitude_client.__file__); "
         "print(resources.files('attitude_client').joinpath('layouts/demo.json').read_text())"],
        capture_output=True, text=True, timeout=60, cwd=tmp_path,
    )
    assert shipped.returncode == 0, shipped.stderr
    where, text = shipped.stdout.split("\n", 1)
    assert str(fresh_venv) in where and text == view.layout_json() + "\n"
    port = free_port()
    proc = subprocess.Popen(
        [str(script), "--connect", f"tcp/127.0.0.1:{free_port()}", "--wait", "0", "--port", str(port)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=tmp_path,
    )
    fox = None
    try:
        fox = FoxgloveClient(f"ws://127.0.0.1:{port}")
        wait_until(lambda: fox.last("/summary") is not None, 15, "a summary")
        assert {"/tf", "/scene", "/summary"} <= set(fox.topics())
        assert fox.last("/summary") == {"vehicles": [], "dropped": 0}
    finally:
        if fox is not None:
            fox.close()
        proc.send_signal(signal.SIGINT)
        log = proc.communicate(timeout=20)[0]
    assert proc.returncode == 0, log
    assert "no service answered" in log, log


def test_the_view_rerun_extra_installs_in_the_fresh_venv(fresh_venv, tmp_path):
    """`pip install './clients/python[view-rerun]'` as docs/view.md says (rerun-sdk from PyPI, or pip's cache), into the
    README's fresh venv: the installed `attitude-view --rerun` starts the wheel's server, whose web viewer answers over
    HTTP (here with no service: it says so and serves anyway), and stops it on Ctrl-C."""
    import urllib.request

    assert "pip install './clients/python[view-rerun]'" in (ROOT / "docs" / "view.md").read_text()
    py = fresh_venv / "bin" / "python"
    out = subprocess.run(
        [str(py), "-m", "pip", "install", "-q", "--disable-pip-version-check", f"{PACKAGE}[view-rerun]"],
        capture_output=True, text=True, timeout=900,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    web, grpc = free_port(), free_port()
    log_path = tmp_path / "view.log"
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(
            [str(fresh_venv / "bin" / "attitude-view"), "--rerun", "--connect", f"tcp/127.0.0.1:{free_port()}",
             "--wait", "0", "--web-port", str(web), "--grpc-port", str(grpc)],
            stdout=log, stderr=subprocess.STDOUT, cwd=tmp_path,
        )
    children: list[int] = []
    try:
        wait_until(lambda: "web viewer on" in log_path.read_text() or proc.poll() is not None, 30, "the web viewer")
        assert proc.poll() is None, log_path.read_text()
        with urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=10) as r:
            assert "re_viewer" in r.read().decode()
        # The server is the fresh venv's own (its rerun_cli), a child of the view.
        children += [int(c) for task in pathlib.Path(f"/proc/{proc.pid}/task").iterdir()
                    for c in (task / "children").read_text().split()]
        exes = [pathlib.Path(f"/proc/{c}/cmdline").read_bytes().split(b"\0")[0].decode() for c in children]
        assert any(e.startswith(str(fresh_venv)) and e.endswith("rerun_cli/rerun") for e in exes), exes
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
    log = log_path.read_text()
    assert proc.returncode == 0 and "no service answered" in log, log
    # Its server stopped with it (and was reaped).
    assert children and not [c for c in children if pathlib.Path(f"/proc/{c}").exists()], children


def test_route_of_gives_the_contracts_test_vectors():
    """The client's route (``routed=True``) against the test vectors written in proto/README.md (Routed
    inputs), read from the contract's text, not from the service's code."""
    text = (ROOT / "proto" / "README.md").read_text()
    line = re.search(r"Test vectors: (.*?)\.", text.replace("\n", " ")).group(1)
    vectors = re.findall(r"`([^`]*)`\s*→\s*`([0-9a-f])`", line)
    assert len(vectors) >= 4, line
    assert [(v, f"{attitude_client.route_of(v):x}") for v, _ in vectors] == vectors
    # Every route is used: 16 000 ids spread within 10 % of even.
    counts = np.bincount([attitude_client.route_of(f"v{i}") for i in range(16000)], minlength=16)
    assert counts.min() > 900 and counts.max() < 1100, counts
