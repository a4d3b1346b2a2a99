"""proto/bad-inputs.json through the real binary over zenoh: one case per row.

proto/BAD_INPUTS.md ("How a row is tested") describes the setup and the checks; tests/it/bad_inputs.rs runs the
same rows against an in-process engine. Rows without `config` use the shared service (each with a healthy
vehicle of its own, switched to the MEKF by a reset before it starts, fed gyro samples or, for the rows of
leaf `imu` and those whose `healthy` says so, raw IMU samples); a row with `config` (overrides of
`service.limits`) starts a service of its own, and the ROS 2 rows (leaves `ros2_imu`, `ros2_mag`) share one with
`service.ros2` enabled, their CDR put on rmw_zenoh's key of the vehicle's topic. A row with `propagated_to` asserts the filters' contract for an
update refused after its propagation (the filter and the vehicle's time stay at that time). No row is an expected
failure: a row the service gets wrong fails its case. A row with `route: "wrong"` goes on a routed key whose
route is not its vehicle's. A row with `missed: N` is two deletes from one publisher numbered 0 and N + 1 (zenoh's
SourceInfo, as an advanced publisher numbers its puts): the service's advanced subscriber finds the N between
missing, no cache to give them back, and reports them.
"""

from __future__ import annotations

import json
import time

import pytest
import zenoh

from attitude_client import ROUTES, route_of
from conftest import ROOT, Collector, ServiceProcess, subscribe_synced, validate, wait_until

ROWS = json.loads((ROOT / "proto" / "bad-inputs.json").read_text(encoding="utf-8"))
#: The keys a row may have (tests/it/bad_inputs.rs refuses any other, `known_issue` included).
ROW_KEYS = {"id", "case", "leaf", "healthy", "vehicle", "payload", "payload_hex", "payload_gen", "config", "code",
            "propagated_to", "route", "ros2_type", "ros2_hash", "missed"}
#: The Jazzy type hashes of the ROS 2 rows' topics (rosbags' own; tests/python/test_ros2.py).
ROS2_TOPICS = {
    "ros2_imu": ("imu/data_raw", "sensor_msgs::msg::dds_::Imu_",
                 "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b"),
    "ros2_mag": ("imu/mag", "sensor_msgs::msg::dds_::MagneticField_",
                 "RIHS01_e80f32f56a20486c9923008fc1a1db07bbb273cbbf6a5b3bfa00835ee00e4dff"),
}


def input_key(prefix: str, row: dict, vehicle: str) -> str:
    """``P/V/<leaf>`` (routed, with a route other than the vehicle's, for ``route: "wrong"``), or rmw_zenoh's
    key of the vehicle's ROS 2 topic for a ROS 2 row."""
    if row["leaf"] not in ROS2_TOPICS:
        key = f"{prefix}/{vehicle}/{row['leaf']}"
        if row.get("route") == "wrong":
            key += f"/{(route_of(vehicle) + 1) % ROUTES:x}"
        return key
    topic, ty, hash_ = ROS2_TOPICS[row["leaf"]]
    return f"0/{vehicle}/{topic}/{row.get('ros2_type', ty)}/{row.get('ros2_hash', hash_)}"
#: Codes decided by the vehicle after the input was queued (the vehicle's `received` counts it).
QUEUED_CODES = {"out_of_order", "duplicate", "time_jump", "mixed_inputs", "not_initialized", "filter_error"}
OBS = [
    '{"body": [1, 0, 0], "ref": [1, 0, 0], "sigma": 0.0001}',
    '{"body": [0, 1, 0], "ref": [0, 1, 0], "sigma": 0.0001}',
]


def gyro(t: float) -> str:
    return '{"t": %r, "omega": [0, 0, 0]}' % float(t)


def vectors(t: float) -> str:
    return '{"t": %r, "obs": [%s, %s]}' % (float(t), OBS[0], OBS[1])


def imu(t: float) -> str:
    """A raw IMU sample of the setup: at rest, level, facing north (the identity attitude), the field in µT."""
    return '{"t": %r, "gyr": [0, 0, 0], "acc": [0, 0, 9.81], "mag": [0, 15.6, -41.7]}' % float(t)


def feed(row: dict) -> str:
    """What the row's healthy vehicle is fed: ``gyro`` or ``imu`` (its `healthy`, else by its leaf)."""
    return row.get("healthy", "imu" if row["leaf"] in ("imu", *ROS2_TOPICS) else "gyro")


def generate(g: dict) -> bytes:
    """``payload_gen`` (rules in proto/BAD_INPUTS.md)."""
    kind = g["kind"]
    if kind == "pad":
        base = g["base"]
        assert g["bytes"] >= len(base.encode())
        text = base + " " * (g["bytes"] - len(base.encode()))
    elif kind == "gyro_batch":
        text = "[" + ", ".join(gyro(g["t0"] + i * g["dt"]) for i in range(g["n"])) + "]"
    elif kind == "vectors_batch":
        text = "[" + ", ".join(vectors(g["t0"] + i * g["dt"]) for i in range(g["n"])) + "]"
    elif kind == "imu_batch":
        text = "[" + ", ".join(imu(g["t0"] + i * g["dt"]) for i in range(g["n"])) + "]"
    elif kind == "obs":
        text = '{"t": %r, "obs": [%s]}' % (float(g["t"]), ", ".join(OBS[i % 2] for i in range(g["n"])))
    elif kind == "nest":
        text = "[" * g["depth"] + "]" * g["depth"]
    else:
        raise ValueError(f"unknown payload_gen {g}")
    return text.encode()


def payload(row: dict) -> bytes:
    if "missed" in row:
        return b""
    if "payload" in row:
        return row["payload"].encode()
    if "payload_hex" in row:
        return bytes.fromhex(row["payload_hex"])
    return generate(row["payload_gen"])


def vehicle_row(client, vehicle):
    return next((r for r in client.vehicles() if r["vehicle"] == vehicle), None)


def init_healthy(client, vehicle: str, fed: str = "gyro"):
    """The setup's healthy vehicle, the MEKF at time 1.5 s: fed gyro samples, its estimate at 1 s with seq 2;
    fed IMU samples, at 1.5 s with seq 15 (one per sample from the alignment at 0.1 s)."""
    client.reset(vehicle, filter="mekf")
    if fed == "imu":
        for i in range(16):
            client.put_raw(vehicle, "imu", imu(i / 10))

        def aligned():
            r = vehicle_row(client, vehicle)
            return r is not None and (r["processed"], r["t"], r["estimates"], r["state"]) == (16, 1.5, 15, "tracking")

        wait_until(aligned, 10, f"{vehicle} to start")
        return
    client.put_raw(vehicle, "gyro", gyro(0.0))
    client.put_raw(vehicle, "vectors", vectors(0.0))
    for i in range(1, 11):
        client.put_raw(vehicle, "gyro", gyro(i / 10))
    client.put_raw(vehicle, "vectors", vectors(1.0))
    client.put_raw(vehicle, "gyro", gyro(1.5))

    def ready():
        r = vehicle_row(client, vehicle)
        return r is not None and (r["processed"], r["t"], r["estimates"], r["state"]) == (14, 1.5, 2, "tracking")

    wait_until(ready, 10, f"{vehicle} to start")


def probe(client, vehicle: str, fed: str = "gyro") -> dict:
    """A gyro sample and a vector set at t = 3 s (an IMU sample for an IMU vehicle); the estimate they give."""
    if fed == "imu":
        client.put_raw(vehicle, "imu", imu(3.0))
    else:
        client.put_raw(vehicle, "gyro", gyro(3.0))
        client.put_raw(vehicle, "vectors", vectors(3.0))

    def done():
        try:
            return client.get_state(vehicle)["t"] == 3.0
        except Exception:
            return False

    wait_until(done, 10, f"the probe's estimate of {vehicle}")
    state = client.get_state(vehicle)
    validate("state", state)  # diagnostics.imu too, for an IMU vehicle
    return state


def without_rejected(estimate: dict) -> dict:
    """The estimate but for its vehicle and ``diagnostics.rejected``."""
    e = json.loads(json.dumps(estimate))
    e.pop("vehicle")
    e["diagnostics"].pop("rejected", None)
    # The bookkeeping of a refused input is not filter state: a rolled-back step is counted, and the
    # gate saw its observations before the update failed.
    e["diagnostics"].pop("rollbacks", None)
    e["diagnostics"].pop("gate", None)
    return e


@pytest.fixture(scope="module")
def baselines(client):
    """The probe's estimate on a vehicle that never saw a bad input, by feed (made when first needed)."""
    made = {}

    def get(fed: str) -> dict:
        if fed not in made:
            init_healthy(client, f"bi-baseline-{fed}", fed)
            made[fed] = probe(client, f"bi-baseline-{fed}", fed)
        return made[fed]

    return get


@pytest.fixture(scope="module")
def ros2_service():
    """The service of the ROS 2 rows (made when first needed), stopped at the end of the module."""
    made = []

    def get():
        if not made:
            svc = ServiceProcess({"filter": {"kind": "mekf"}, "ros2": {"enabled": True}}, prefix="bi-ros2")
            c = svc.client()
            made.append((svc, c))
            svc.wait_ready(c)
        return made[0]

    yield get
    for svc, c in made:
        c.close()
        code, _ = svc.stop()
        assert code == 0, svc.log()[-4000:]
        assert "panicked" not in svc.log()


@pytest.fixture
def service_for(service, client, ros2_service):
    """(ServiceProcess, client) for a row: the shared service, or one of its own for a row with `config`."""
    made = []

    def get(row):
        if row["leaf"] in ROS2_TOPICS:
            return ros2_service()
        if "config" not in row:
            return service, client
        svc = ServiceProcess({"filter": {"kind": "mekf"}, "limits": row["config"]}, prefix=f"bi-{row['id']}")
        c = svc.client()
        made.append((svc, c))
        svc.wait_ready(c)
        return svc, c

    yield get
    for svc, c in made:
        c.close()
        code, _ = svc.stop()
        assert code == 0, svc.log()[-4000:]
        assert "panicked" not in svc.log()


def params():
    return [pytest.param(i, row, id=row["id"]) for i, row in enumerate(ROWS)]


def test_rows_have_known_keys_only():
    assert [(r["id"], set(r) - ROW_KEYS) for r in ROWS if set(r) - ROW_KEYS] == []


@pytest.mark.parametrize("index, row", params())
def test_bad_input(service_for, baselines, index, row):
    svc, c = service_for(row)
    prefix = svc.prefix
    healthy = f"bi-h{index}"
    fed = feed(row)
    baseline = baselines(fed)
    init_healthy(c, healthy, fed)
    target = row.get("vehicle", healthy)
    code = row["code"]
    reset = row["leaf"] == "reset"
    own_input = target == healthy and not reset

    state0 = c.get_state(healthy)
    att0, cov0 = c.get_attitude(healthy), c.get_covariance(healthy)
    row0 = vehicle_row(c, healthy)
    rejected0 = c.health()["rejected"]
    existed = vehicle_row(c, target) is not None
    rejections = Collector()
    sub = subscribe_synced(c, c.subscribe_rejections, rejections)
    fails = []
    in_key = input_key(prefix, row, target)

    if reset:
        replies = c.query(f"{target}/reset", payload=payload(row))
        if len(replies) != 1 or replies[0][1]:
            fails.append(f"the reset was answered {[(k, ok, p[:200]) for k, ok, p in replies]}")
        else:
            err = json.loads(replies[0][2])
            validate("error", err)
            if err["code"] != code:
                fails.append(f"reset refused with {err['code']} ({err['message']}), not {code}")
            if not err["message"]:
                fails.append("empty message")
            if err["key"] != f"{prefix}/{target}/reset":
                fails.append(f"the error's key is {err['key']}")
    elif "missed" in row:
        # A publisher (declared only for its id) whose puts 1..N never arrive: zenoh-ext asks for them on
        # its cache's key, nothing answers, and it reports N missed before the delete numbered N + 1.
        source = c.session.declare_publisher(in_key)
        c.session.delete(in_key, source_info=zenoh.SourceInfo(source.id, 0))
        c.session.delete(in_key, source_info=zenoh.SourceInfo(source.id, row["missed"] + 1))
        deadline = time.monotonic() + 10.0
        while not rejections.snapshot() and time.monotonic() < deadline:
            time.sleep(0.005)
        source.undeclare()
    else:
        if row["leaf"] in ROS2_TOPICS:
            c.session.put(in_key, payload(row))
        else:
            c.session.put(in_key, payload(row), encoding=zenoh.Encoding.APPLICATION_JSON)
        deadline = time.monotonic() + 10.0
        while not rejections.snapshot() and time.monotonic() < deadline:
            time.sleep(0.005)

    # Right after the row.
    try:
        state1 = c.get_state(healthy)
        att1, cov1 = c.get_attitude(healthy), c.get_covariance(healthy)
    except Exception as e:  # noqa: BLE001 - a reset that was wrongly accepted
        state1 = att1 = cov1 = repr(e)
    if (att1, cov1, state1) != (att0, cov0, state0):
        fails.append(f"the healthy vehicle's estimate changed: seq {state0['seq']} t {state0['t']} -> {str(state1)[:200]}")
    row1 = vehicle_row(c, healthy)
    # A refused update after the propagation to T: the filter, hence the vehicle's time, stays at T.
    want = dict(row0, rejected=row0["rejected"] + own_input,
                received=row0["received"] + (own_input and code in QUEUED_CODES),
                t=row.get("propagated_to", row0["t"]))
    if row1 != want:
        fails.append(f"the healthy vehicle's P/@/vehicles row is {row1}, want {want}")
    rejected1 = c.health()["rejected"]
    delta = {k: rejected1.get(k, 0) - rejected0.get(k, 0) for k in set(rejected0) | set(rejected1)}
    delta = {k: d for k, d in delta.items() if d}
    if delta != {code: 1}:
        fails.append(f"P/@/health rejected grew by {delta}, want {{{code}: 1}}")
    if target != healthy and not existed and code != "not_initialized" and vehicle_row(c, target) is not None:
        fails.append(f"the refused input created vehicle {target}")

    # The probe: the filter is that of a vehicle that never saw the row.
    try:
        p = probe(c, healthy, fed)
        # The propagation to T is kept: one propagation more than the baseline's, nothing else different.
        want_propagations = baseline["diagnostics"]["propagations"] + ("propagated_to" in row)
        if p["diagnostics"]["propagations"] != want_propagations:
            fails.append(f"diagnostics.propagations is {p['diagnostics']['propagations']}, want {want_propagations}")
        p = json.loads(json.dumps(p))
        p["diagnostics"]["propagations"] = baseline["diagnostics"]["propagations"]
        # The puts zenoh reported missed are counted in the vehicle's diagnostics.
        if p["diagnostics"].get("missed", 0) != row.get("missed", 0):
            fails.append(f"diagnostics.missed is {p['diagnostics'].get('missed')}, want {row.get('missed', 0)}")
        p["diagnostics"].pop("missed", None)
        # A refused filter step is rolled back and counted.
        want_rollbacks = baseline["diagnostics"].get("rollbacks", 0) + (own_input and code == "filter_error")
        if p["diagnostics"].get("rollbacks", 0) != want_rollbacks:
            fails.append(f"diagnostics.rollbacks is {p['diagnostics'].get('rollbacks', 0)}, want {want_rollbacks}")
        if without_rejected(p) != without_rejected(baseline):
            fails.append(f"the probe's estimate differs from a vehicle that never saw the row:\n{p}\n{baseline}")
        want_rejected = {code: 1} if own_input else {}
        if p["diagnostics"].get("rejected", {}) != want_rejected:
            fails.append(f"diagnostics.rejected is {p['diagnostics'].get('rejected')}, want {want_rejected}")
    except BaseException as e:  # noqa: BLE001 - pytest.fail from wait_until
        fails.append(f"the probe: {e}")

    c.health()  # a round trip: what the service published before it answered has arrived
    sub.undeclare()
    got = rejections.snapshot()
    if reset:
        if got:
            fails.append(f"a reset published rejections: {got}")
    elif len(got) != 1:
        fails.append(f"{len(got)} rejections, want exactly one: {got}")
    else:
        msg = got[0]
        validate("error", msg)
        if msg["code"] != code:
            fails.append(f"rejected with {msg['code']} ({msg['message']}), not {code}")
        if not msg["message"]:
            fails.append("empty message")
        if msg["key"] != in_key:
            fails.append(f"the rejection's key is {msg['key']}")
    assert not fails, f"{row['id']} ({row['case']}):\n" + "\n".join(fails)
