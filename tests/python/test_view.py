"""`attitude-view` (clients/python/src/attitude_client/view/), headless: the real service, `simulate` for four
spacecraft with the demo's filters, the view as a subprocess (its console script, as a user runs it), and a client of
the Foxglove WebSocket protocol written here (websockets; subprotocol `foxglove.sdk.v1`, the protocol's current name:
`serverInfo`, `advertise`, `subscribe`, binary message data `0x01 | subscription id u32 LE | log time u64 LE |
payload`). The JSON topics are parsed as JSON; the 3D topics are decoded with protobuf from the schema the view
advertises (a FileDescriptorSet), not with the SDK that encoded them.

What is checked, against what the service and the simulator publish (the test's own subscriptions and queries):
the topics and their schemas; each vehicle's last `/V/attitude` is the service's estimate (`get_state`: `q`, `t`,
`seq` exactly, 3σ = 3·`sigma_deg` exactly, roll/pitch/yaw against SciPy), none lost with `--max-rate 0`; every
`/V/error` is the body-axis error of its estimate against the truth at the same `t` (`sim.axis_errors_rad`), its
±3σ and NEES; the ESS of the particle filters and its absence for the MEKF; rejection counts by code after two bad
inputs; `/tf`, `/scene` and `/summary`; the shipped layout file references only advertised topics and fields.
`attitude-view --demo` starts the demo itself and ends with the demo's own counts.
"""

from __future__ import annotations

import json
import pathlib
import re
import signal
import subprocess
import sys
import threading
import time
from importlib import resources

import numpy as np
import pytest

from scipy.spatial.transform import Rotation

import foxglove  # noqa: F401  (the view's extra: scripts/python-tests.sh installs it; a missing one fails here)
from attitude_client import view as view_module
from conftest import BIN, ROOT, ServiceProcess, free_port, wait_until
from foxglove_ws import FoxgloveClient
from sim import attitude_nees, axis_errors_rad, to_rotation

PREFIX = "viewtest/attitude"
VEHICLES = ("sc1", "sc2", "sc3", "sc4")
FILTERS = {"sc1": "qpf:average", "sc2": "qpf:propagated", "sc3": "usque:average", "sc4": "mekf"}
PARTICLES = 300
DURATION_S = 40
DEMO_S = 7200


def view_command() -> list[str]:
    script = pathlib.Path(sys.executable).parent / "attitude-view"
    assert script.exists(), f"{script}: the console script is not installed (scripts/python-tests.sh installs it)"
    return [str(script)]


class ViewProcess:
    """`attitude-view --port <free port> ARGS`, its output (and a demo's, which inherits it) in a file."""

    def __init__(self, args: list[str], workdir: pathlib.Path):
        self.port = free_port()
        self.log_path = workdir / f"view-{self.port}.log"
        self._log = open(self.log_path, "wb")
        self.proc = subprocess.Popen(
            view_command() + ["--port", str(self.port), *args], stdout=self._log, stderr=subprocess.STDOUT
        )

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def client(self) -> FoxgloveClient:
        return FoxgloveClient(f"ws://127.0.0.1:{self.port}")

    def stop(self) -> tuple[int, str]:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self._log.close()
        return self.proc.returncode, self.log()


# ------------------------------------------------------------------------------------------------------------------
# One run shared by the tests of the module: the service, the view, four simulated spacecraft, two bad inputs.


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    svc = ServiceProcess(prefix=PREFIX)
    client = svc.client()
    view = None
    fox = None
    try:
        svc.wait_ready(client)
        estimates, truths = [], []
        lock = threading.Lock()

        def keep(into):
            def cb(msg):
                with lock:
                    into.append(msg)
            return cb

        subs = [client.subscribe_estimates(keep(estimates)), client.subscribe_truth(keep(truths))]
        client.health()  # the service has the subscriptions

        view = ViewProcess(["--connect", svc.endpoint, "--prefix", PREFIX, "--max-rate", "0", "--republish", "0.25"],
                           tmp_path_factory.mktemp("view"))
        fox = view.client()
        wait_until(lambda: fox.server_info is not None, 10, "the view's serverInfo")
        wait_until(lambda: {"/tf", "/scene", "/summary"} <= set(fox.topics()), 10, "the fixed topics")

        # Create the vehicles (each reset publishes an estimate), so that the view advertises their topics and this
        # client subscribes to them before the simulation starts; a second reset proves the subscriptions active.
        expected = {view_module.vehicle_topics(v)[leaf] for v in VEHICLES for leaf in view_module.VEHICLE_LEAVES}
        for v in VEHICLES:
            kind, _, fid = FILTERS[v].partition(":")
            client.reset(v, filter=kind, **({"fiducial": fid, "particles": PARTICLES} if kind == "qpf" else {}),
                         **({"fiducial": fid} if kind == "usque" else {}), q=(1, 0, 0, 0), t=0.0)
        wait_until(lambda: expected <= set(fox.topics()), 15, "every vehicle's topics advertised")
        # The protocol does not acknowledge a subscription: reset again until the client has a message of each.
        deadline = time.monotonic() + 20
        while missing := [v for v in VEHICLES if not fox.got(f"/{v}/attitude")]:
            assert time.monotonic() < deadline, (
                f"no message of {missing} reached the client; its channels {sorted(fox.topics())}, "
                f"its subscriptions {fox.subscriptions}, its errors {fox.errors}; the view's log:\n{view.log()}"
            )
            for v in missing:
                client.reset(v, q=(1, 0, 0, 0), t=0.0)
            time.sleep(0.5)

        sim = subprocess.run(
            [str(BIN), "simulate", "--scenario", "star-tracker", "--duration", str(DURATION_S), "--speed", "0",
             "--vehicles", str(len(VEHICLES)), "--filters", ",".join(FILTERS[v] for v in VEHICLES),
             "--particles", str(PARTICLES), "--prefix", PREFIX, "--connect", svc.endpoint],
            capture_output=True, text=True, timeout=120,
        )
        assert sim.returncode == 0, sim.stderr
        # The service may still be working through what the simulation sent as fast as it could (two particle
        # filters); 60 s, and a failure says where each vehicle stands and what its health counted.
        try:
            wait_until(lambda: all(client.get_state(v)["t"] == DURATION_S for v in VEHICLES), 60, "the last estimates")
        except pytest.fail.Exception:
            states = {v: client.get_state(v).get("t") for v in VEHICLES}
            pytest.fail(f"not every vehicle reached t = {DURATION_S}: {states}; health {client.health()}; "
                        f"simulate: {sim.stdout} {sim.stderr}")
        final = {v: client.get_state(v) for v in VEHICLES}

        def shown(v):
            last = fox.last(f"/{v}/attitude")
            return last is not None and last["seq"] == final[v]["seq"]

        wait_until(lambda: all(shown(v) for v in VEHICLES), 15, "the view showing every vehicle's last estimate")

        # Two bad inputs for sc4: a malformed gyro sample and one older than what it processed.
        client.put_raw("sc4", "gyro", json.dumps({"t": 100.0, "omega": [0.0, 0.0]}))
        client.put_raw("sc4", "gyro", json.dumps({"t": 0.5, "omega": [0.0, 0.0, 0.0]}))
        wait_until(lambda: (fox.last("/sc4/rejections") or {}).get("total") == 2, 15, "two rejections of sc4")
        # Two republications of the summary after the last estimate.
        n_summary = len(fox.got("/summary"))
        wait_until(lambda: len(fox.got("/summary")) >= n_summary + 2, 10, "the summary")
        for s in subs:
            s.undeclare()
        with lock:
            data = {"estimates": list(estimates), "truths": list(truths), "final": final, "fox": fox}
        yield data
    finally:
        if fox is not None:
            fox.close()
        if view is not None:
            code, log = view.stop()
            assert code == 0, log
            assert "Traceback" not in log, log
        client.close()
        svc.stop()


def test_the_view_advertises_its_topics_with_their_schemas(run):
    fox = run["fox"]
    assert fox.server_info["name"] == "attitude-view"
    topics = fox.topics()
    expected = {"/tf", "/scene", "/summary"} | {
        view_module.vehicle_topics(v)[leaf] for v in VEHICLES for leaf in view_module.VEHICLE_LEAVES
    }
    assert set(topics) == expected
    assert topics["/tf"]["schemaName"] == "foxglove.FrameTransforms" and topics["/tf"]["encoding"] == "protobuf"
    assert topics["/scene"]["schemaName"] == "foxglove.SceneUpdate" and topics["/scene"]["encoding"] == "protobuf"
    schemas = view_module.schemas()
    for topic, ch in topics.items():
        if ch["encoding"] != "json":
            continue
        leaf = topic if topic == "/summary" else topic.rsplit("/", 1)[1]
        assert ch["schemaEncoding"] == "jsonschema"
        assert json.loads(ch["schema"]) == schemas[leaf]
        assert ch["schemaName"] == schemas[leaf]["title"]
    assert fox.errors == []


def test_every_json_message_validates_against_its_advertised_schema(run):
    jsonschema = pytest.importorskip("jsonschema")
    fox = run["fox"]
    for topic, ch in fox.topics().items():
        if ch["encoding"] != "json":
            continue
        validator = jsonschema.Draft202012Validator(json.loads(ch["schema"]))
        for _, msg in fox.got(topic):
            errors = list(validator.iter_errors(msg))
            assert not errors, (topic, errors[0].message, msg)


def test_each_vehicle_shows_the_services_estimate(run):
    fox, final = run["fox"], run["final"]
    by_seq = {(e["vehicle"], e["seq"]): e for e in run["estimates"]}
    for v in VEHICLES:
        got = [m for _, m in fox.got(f"/{v}/attitude")]
        last, state = got[-1], final[v]
        assert last["q"] == state["q"] and last["t"] == state["t"] == DURATION_S and last["seq"] == state["seq"]
        assert [last["sigma_deg"][a] for a in "xyz"] == state["sigma_deg"]
        assert [last["three_sigma_deg"][a] for a in "xyz"] == [3.0 * s for s in state["sigma_deg"]]
        assert last["filter"] == FILTERS[v]
        assert [last["bias_deg_h"][a] for a in "xyz"] == pytest.approx(np.degrees(state["bias"]) * 3600.0, rel=1e-12)
        yaw, pitch, roll = to_rotation(state["q"]).as_euler("ZYX", degrees=True)
        assert [last["euler_deg"][k] for k in ("roll", "pitch", "yaw")] == pytest.approx([roll, pitch, yaw], abs=1e-9)
        # --max-rate 0: every estimate since the subscription, in order, each the service's own.
        seqs = [m["seq"] for m in got]
        assert seqs == list(range(seqs[0], seqs[-1] + 1)), seqs
        assert seqs[-1] - seqs[0] >= DURATION_S
        for m in got:
            e = by_seq[(v, m["seq"])]
            assert m["q"] == e["q"] and m["t"] == e["t"]
        assert last["received"] >= len(got)


def test_each_error_is_the_estimate_against_the_truth_at_its_time(run):
    fox = run["fox"]
    truth = {(m["vehicle"], m["t"]): m for m in run["truths"]}
    by_seq = {(e["vehicle"], e["seq"]): e for e in run["estimates"]}
    for v in VEHICLES:
        errors = [m for _, m in fox.got(f"/{v}/error")]
        shown = [m for _, m in fox.got(f"/{v}/attitude")]
        # One error per estimate of the simulation (its truth comes before it). At t = 0 the resets (the test's,
        # before the simulator's truth, and the simulator's) may have one at most.
        assert len([m for m in errors if m["t"] > 0]) == len([m for m in shown if m["t"] > 0]) >= DURATION_S
        assert len([m for m in errors if m["t"] == 0]) <= 1
        inside = 0
        for m in errors:
            e = by_seq[(v, m["seq"])]
            q_true = to_rotation(truth[(v, e["t"])]["q"])
            expected = np.degrees(axis_errors_rad(q_true, e["q"]))
            assert [m["error_deg"][a] for a in "xyz"] == pytest.approx(expected, abs=1e-9)
            three = [3.0 * s for s in e["sigma_deg"]]
            assert [m["plus_3sigma_deg"][a] for a in "xyz"] == three
            assert [m["minus_3sigma_deg"][a] for a in "xyz"] == [-s for s in three]
            assert m["within_3sigma"] == all(abs(x) <= s for x, s in zip(expected, three))
            assert m["nees"] == pytest.approx(attitude_nees(q_true, e), rel=1e-9)
            assert m["angle_deg"] == pytest.approx(np.degrees((to_rotation(e["q"]).inv() * q_true).magnitude()),
                                                   abs=1e-9)
            assert m["truth_q"] == truth[(v, e["t"])]["q"]
            inside += m["within_3sigma"]
        # The filters are consistent on this scenario: their errors are mostly inside 3σ.
        assert inside >= 0.8 * len(errors), (v, inside, len(errors))


def test_the_diagnostics_carry_the_ess_of_the_particle_filters(run):
    fox = run["fox"]
    by_seq = {(e["vehicle"], e["seq"]): e for e in run["estimates"]}
    for v in VEHICLES:
        diags = [m for _, m in fox.got(f"/{v}/diagnostics")]
        shown = [m["seq"] for _, m in fox.got(f"/{v}/attitude")]
        # One per estimate, as /V/attitude (whose subscription may have begun an estimate later or sooner).
        assert diags and [m["seq"] for m in diags if m["seq"] >= shown[0]] == [s for s in shown if s >= diags[0]["seq"]]
        for m in diags:
            d = by_seq[(v, m["seq"])]["diagnostics"]
            assert m["updates"] == d["updates"] and m["propagations"] == d["propagations"]
            if FILTERS[v].startswith("qpf"):
                assert m["ess"] == d["ess"] and m["particles"] == PARTICLES
                assert m["ess_fraction"] == d["ess"] / PARTICLES
                assert 1.0 <= m["ess"] <= PARTICLES
            else:
                assert "ess" not in m and "particles" not in m
                if m["updates"] > 0 and "nis" in d:
                    assert m["nis"] == d["nis"] and m["nis_dof"] == d["nis_dof"]
        assert diags[-1]["updates"] >= DURATION_S


def test_rejections_are_counted_by_code(run):
    fox = run["fox"]
    last = fox.last("/sc4/rejections")
    assert last["vehicle"] == "sc4" and last["total"] == 2
    assert last["by_code"]["bad_request"] == 1 and last["by_code"]["out_of_order"] == 1
    assert set(last["by_code"]) == set(view_module.REJECTION_CODES)
    assert sum(last["by_code"].values()) == 2
    assert last["last"]["code"] in ("bad_request", "out_of_order")
    assert last["last"]["key"] == f"{PREFIX}/sc4/gyro"
    for v in ("sc1", "sc2", "sc3"):
        assert fox.got(f"/{v}/rejections") == []
    # The view's codes are the contract's.
    enum = json.loads((ROOT / "proto" / "schemas" / "error.schema.json").read_text())["properties"]["code"]["enum"]
    assert sorted(view_module.REJECTION_CODES) == sorted(enum)


def _latest_transforms(fox) -> dict[str, dict]:
    frames: dict[str, dict] = {}
    for _, msg in fox.got("/tf"):
        for tf in msg.get("transforms", []):
            frames[tf["child_frame_id"]] = tf
    return frames


def test_the_3d_scene_holds_each_estimate_and_its_truth(run):
    fox, final = run["fox"], run["final"]
    truth = {(m["vehicle"], m["t"]): m for m in run["truths"]}
    frames = _latest_transforms(fox)
    assert set(frames) == set(VEHICLES) | {f"{v}/truth" for v in VEHICLES}
    places = set()
    for v in VEHICLES:
        est, tru = frames[v], frames[f"{v}/truth"]
        q = final[v]["q"]
        assert est["parent_frame_id"] == "world"
        assert [est["rotation"].get(k, 0.0) for k in "xyzw"] == [q[k] for k in "xyzw"]
        qt = truth[(v, DURATION_S)]["q"]
        assert [tru["rotation"].get(k, 0.0) for k in "xyzw"] == [qt[k] for k in "xyzw"]
        assert est.get("translation", {}) == tru.get("translation", {})
        places.add(tuple(est.get("translation", {}).get(k, 0.0) for k in "xyz"))
    assert len(places) == len(VEHICLES), places  # each vehicle at its own place
    entities = {}
    for _, msg in fox.got("/scene"):
        for ent in msg.get("entities", []):
            entities[ent["id"]] = ent
    for v in VEHICLES:
        body, ghost, label = entities[v], entities[f"{v}/truth"], entities[f"{v}/label"]
        assert body["frame_id"] == v and body["frame_locked"] and len(body["arrows"]) == 3 and len(body["cubes"]) == 1
        assert ghost["frame_id"] == f"{v}/truth" and len(ghost["arrows"]) == 3
        assert label["texts"][0]["text"].startswith(f"{v}  {FILTERS[v]}")


def test_the_summary_has_a_row_per_vehicle(run):
    fox, final = run["fox"], run["final"]
    rows = {r["vehicle"]: r for r in run["fox"].last("/summary")["vehicles"]}
    assert set(rows) == set(VEHICLES)
    for v in VEHICLES:
        r = rows[v]
        last_error = fox.last(f"/{v}/error")
        assert r["seq"] == final[v]["seq"] and r["filter"] == FILTERS[v]
        assert r["error_deg"] == last_error["angle_deg"] and r["within_3sigma"] == last_error["within_3sigma"]
        assert r["three_sigma_deg"] == 3.0 * max(final[v]["sigma_deg"])
        assert r["ess"] == final[v]["diagnostics"].get("ess")
        assert r["rejected"] == (2 if v == "sc4" else 0)
    assert fox.last("/summary")["dropped"] == 0
    # Log times: the view's wall clock, never decreasing.
    times = [t for topic in fox.topics() for t, _ in fox.got(topic)]
    assert times and abs(max(times) / 1e9 - time.time()) < 120
    for topic in fox.topics():
        ts = [t for t, _ in fox.got(topic)]
        assert ts == sorted(ts), topic


def _layout_paths(layout: dict) -> list[str]:
    """Every topic or message path a layout refers to."""
    out = []
    for pid, config in layout["configById"].items():
        kind = pid.split("!", 1)[0]
        if kind == "Plot":
            out += [p["value"] for p in config["paths"]]
        elif kind == "3D":
            out += list(config["topics"])
        elif kind == "Table":
            out.append(config["topicPath"])
        else:
            raise AssertionError(f"a panel the test does not know: {pid}")
    return out


def _mosaic_ids(node) -> list[str]:
    if isinstance(node, str):
        return [node]
    assert set(node) == {"direction", "first", "second", "splitPercentage"}, node
    return _mosaic_ids(node["first"]) + _mosaic_ids(node["second"])


def _resolve(schema: dict, fields: list[str]) -> None:
    for f in fields:
        if schema.get("type") == "array":
            schema = schema["items"]
        assert f in schema.get("properties", {}), (f, schema)
        schema = schema["properties"][f]


def check_layout(layout: dict, topics: dict[str, dict]) -> None:
    ids = _mosaic_ids(layout["layout"])
    assert sorted(ids) == sorted(layout["configById"]) and len(set(ids)) == len(ids)
    assert set(layout) == {"configById", "globalVariables", "userNodes", "playbackConfig", "layout"}
    for path in _layout_paths(layout):
        m = re.fullmatch(r"(/[A-Za-z0-9_/-]+?)(?:\.([A-Za-z0-9_.]+))?", path)
        assert m, path
        topic, fields = m.group(1), m.group(2)
        assert topic in topics, f"the layout refers to {topic}, which the view does not advertise"
        if fields:
            _resolve(json.loads(topics[topic]["schema"]), fields.split("."))


def test_the_shipped_layout_refers_only_to_what_the_view_advertises(run):
    shipped = resources.files("attitude_client").joinpath("layouts/demo.json").read_text(encoding="utf-8")
    assert shipped == view_module.layout_json(), "layouts/demo.json is stale: attitude-view --write-layout it again"
    topics = run["fox"].topics()
    check_layout(json.loads(shipped), topics)
    check_layout(view_module.layout(VEHICLES, truth=False), topics)
    # The check can fail: a path to a field the schema does not have, a topic nobody advertises.
    broken = json.loads(shipped)
    broken["configById"]["Plot!ess"]["paths"][0]["value"] = "/sc1/diagnostics.effective_sample_size"
    with pytest.raises(AssertionError):
        check_layout(broken, topics)
    broken["configById"]["Plot!ess"]["paths"][0]["value"] = "/sc9/diagnostics.ess"
    with pytest.raises(AssertionError):
        check_layout(broken, topics)


def test_write_layout_writes_the_shipped_file(tmp_path):
    out = tmp_path / "layout.json"
    done = subprocess.run(view_command() + ["--write-layout", str(out)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert out.read_text(encoding="utf-8") == view_module.layout_json()
    done = subprocess.run(view_command() + ["--write-layout", "-", "--layout-vehicles", "a,b", "--no-truth"],
                          capture_output=True, text=True, timeout=60)
    assert json.loads(done.stdout) == view_module.layout(["a", "b"], truth=False)


def test_the_arithmetic_agrees_with_scipy():
    rng = np.random.default_rng(7)
    for _ in range(200):
        est, tru = Rotation.random(random_state=rng), Rotation.random(random_state=rng)
        qe = dict(zip("xyzw", est.as_quat()))
        qt = dict(zip("xyzw", tru.as_quat()))
        err, angle = view_module.error_deg(qe, qt)
        assert err == pytest.approx(np.degrees(axis_errors_rad(tru, qe)), abs=1e-9)
        assert angle == pytest.approx(np.degrees((est.inv() * tru).magnitude()), abs=1e-9)
        yaw, pitch, roll = est.as_euler("ZYX", degrees=True)
        assert view_module.euler_zyx_deg(qe) == pytest.approx((roll, pitch, yaw), abs=1e-7)


class _Summaries:
    """A sink that keeps the summaries and the estimates' ``seq`` (and is slow, as a loaded machine's view is)."""

    def __init__(self, seconds_per_message: float = 0.0):
        self.summaries: list[dict] = []
        self.seqs: list[int] = []
        self.delay = seconds_per_message

    def add_vehicle(self, vehicle, log_ns):
        pass

    def publish(self, vehicle, leaf, message, log_ns):
        if leaf == "attitude":
            self.seqs.append(message["seq"])
            time.sleep(self.delay)

    def scene(self, poses, log_ns, republish):
        pass

    def summary(self, message, log_ns):
        self.summaries.append(message)


def _estimate(seq: int) -> dict:
    return {"vehicle": "v", "t": float(seq), "seq": seq, "q": {"w": 1.0, "x": 0.0, "y": 0.0, "z": 0.0},
            "sigma_deg": [0.1, 0.1, 0.1], "filter": "mekf"}


@pytest.mark.parametrize("hurry", [False, True])
def test_a_stopped_view_shows_what_it_received_unless_stopped_twice(hurry):
    """A view stopped while behind (its stream holds 400 estimates, each taking 8 ms to show: 3.2 s of work) still
    shows every one, and its last summary is the last estimate's; stopped twice, it says how many it did not show."""
    import zenoh

    from attitude_client import MessageStream

    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("listen/endpoints", "[]")
    n = 400
    with zenoh.open(conf) as session:
        stream = MessageStream(session, ["drain/*/estimate"], maxsize=n)
        try:
            for seq in range(1, n + 1):
                session.put("drain/v/estimate", json.dumps(_estimate(seq)))
            wait_until(lambda: len(stream) == n, 10, "the stream to hold every estimate")
            sink = _Summaries(seconds_per_message=0.008)
            view = view_module.View(sink, prefix="drain", max_rate=0, republish_s=60.0)
            stop, second = threading.Event(), threading.Event()
            stop.set()
            said: list[str] = []
            if hurry:
                threading.Timer(1.2, second.set).start()
            unshown = view.run(stream, stop, second, said.append)
        finally:
            stream.close()
    if not hurry:
        assert unshown == 0 and sink.seqs == list(range(1, n + 1)), (unshown, sink.seqs[-3:])
        assert sink.summaries[-1]["vehicles"][0]["seq"] == n, sink.summaries[-1]
        assert view.vehicles["v"].received == n
        assert any(s.startswith("still showing ") for s in said) and not any("not shown" in s for s in said), said
    else:
        received = view.vehicles["v"].received
        assert 0 < unshown < n and received + unshown == n, (received, unshown)
        assert said[-1] == f"{unshown} messages received before the stop were not shown (stopped twice)", said
        assert sink.summaries[-1]["vehicles"][0]["seq"] == received, sink.summaries[-1]


def test_a_stopped_view_publishes_the_estimate_its_rate_limit_held():
    """At 1 estimate/s, the second and third of a burst are held: the stop publishes the newest at once."""
    sink = _Summaries()
    view = view_module.View(sink, prefix="drain", max_rate=1.0, republish_s=60.0)
    now = time.monotonic()
    for seq in (1, 2, 3):
        view.handle("drain/v/estimate", _estimate(seq), now + 0.01 * seq)
    assert sink.seqs == [1]

    class Empty:
        dropped = 0

        def __len__(self):
            return 0

    stop = threading.Event()
    stop.set()
    assert view.run(Empty(), stop) == 0
    assert sink.seqs == [1, 3] and sink.summaries[-1]["vehicles"][0]["seq"] == 3, (sink.seqs, sink.summaries)


def test_demo_starts_the_demo_and_views_it(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    # 7200 s at 2400×: 3 s, 240 estimates a second per vehicle (the view joins within a second; --max-rate 30 holds
    # most of them back, never the last).
    view = ViewProcess(["--demo", "--bin", str(BIN), "--connect", endpoint, "--", "--speed", "2400",
                        "--duration", str(DEMO_S)], tmp_path)
    fox = None
    try:
        fox = view.client()
        demo = [pid for pid in _children(view.proc.pid)
                if pathlib.Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")[1:2] == [b"demo"]]
        assert len(demo) == 1, "the demo is a child of the view"

        def rows():
            last = fox.last("/summary")
            return {r["vehicle"]: r for r in last["vehicles"]} if last else {}

        wait_until(lambda: "the demo ended" in view.log(), 60, "the demo to end")
        # The view goes on serving what it showed: the summary is repeated, at the end of the run.
        n = len(fox.got("/summary"))
        wait_until(lambda: len(fox.got("/summary")) > n, 10, "a summary after the demo ended")
        final = rows()
        assert {v: r["filter"] for v, r in final.items()} == {
            "sc1": "qpf:average", "sc2": "qpf:propagated", "sc3": "usque:average", "sc4": "mekf"}
        assert all(r["t"] == DEMO_S for r in final.values()), final
        for v in final:
            assert fox.got(f"/{v}/error"), v
        assert view.proc.poll() is None
    finally:
        if fox is not None:
            fox.close()
        code, log = view.stop()
    assert code == 0, log
    assert "the demo ended (exit code 0)" in log, log[-2000:]
    # The demo's own table: the view (default --max-rate, bursts at --speed 0) ended on each vehicle's last
    # estimate, since the latest is never held back.
    table = {m.group(1): int(m.group(2))
             for m in re.finditer(rf"^(sc\d)\s+\S+\s+{DEMO_S}\s+.*?\s(\d+)\s+(?:yes|NO)\s*$", log, re.M)}
    assert set(table) == {"sc1", "sc2", "sc3", "sc4"}, log[-3000:]
    assert {v: r["seq"] for v, r in final.items()} == table, (final, table)


def _children(pid: int) -> list[int]:
    out = []
    for task in pathlib.Path(f"/proc/{pid}/task").iterdir():
        out += [int(c) for c in (task / "children").read_text().split()]
    return out

