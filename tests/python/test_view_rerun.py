"""`attitude-view --rerun` (clients/python/src/attitude_client/view/rerun_sink.py), headless: the real service,
`simulate` for four spacecraft with the demo's filters, the view as a subprocess (its console script), and a client of
the Rerun server it starts: the wheel's `rerun` command connected to the view's gRPC server (`rerun
rerun+http://…/proxy --save FILE.rrd`, what a viewer receives, saved until the server goes away), read back with
rerun's chunk API (`rerun.chunk.RrdReader`, Arrow record batches), not with the logging calls that wrote it.

What is checked, against what the service and the simulator publish (the test's own subscriptions and queries), as
tests/python/test_view.py does for the Foxglove sink: the entities; each vehicle's attitude entities hold the service's
estimates (`q`, `t`, `seq` exactly, 3σ = 3·`sigma_deg`, roll/pitch/yaw against SciPy), none lost with `--max-rate 0`;
every error is the body-axis error of its estimate against the truth at the same `t` (`sim.axis_errors_rad`), its
±3σ and NEES; the ESS of the particle filters and its absence for the MEKF; the rejection counts by code after two
bad inputs; the 3D transforms of estimate and truth; the summary table; the blueprint's views refer only to logged
entities; both servers listen on 127.0.0.1 only, and the web viewer is served from the wheel.
"""

from __future__ import annotations

import collections
import json
import re
import signal
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from scipy.spatial.transform import Rotation

import rerun  # noqa: F401  (the view-rerun extra: scripts/python-tests.sh installs it; a missing one fails here)
from rerun.chunk import RrdReader

from attitude_client import view as view_module
from attitude_client.view import rerun_sink
from conftest import BIN, ServiceProcess, free_port, wait_until
from sim import attitude_nees, axis_errors_rad, to_rotation

PREFIX = "viewrerun/attitude"
VEHICLES = ("sc1", "sc2", "sc3", "sc4")
FILTERS = {"sc1": "qpf:average", "sc2": "qpf:propagated", "sc3": "usque:average", "sc4": "mekf"}
PARTICLES = 300
DURATION_S = 30


def read_rrd(path: Path) -> tuple[dict[str, list[dict]], dict[str, list[dict]]]:
    """``(recording, the last blueprint)``: per entity path its rows in logging order (row ids), each ``{column: value}`` with
    timelines as int64 (ns for ``wall`` and ``t``) and ``static``."""

    def rows_of(stream) -> dict[str, list[dict]]:
        out: dict[str, list[dict]] = collections.defaultdict(list)
        for chunk in stream:
            rb = chunk.to_record_batch()
            cols = {}
            for name in rb.schema.names:
                col = rb.column(name)
                if pa.types.is_timestamp(col.type) or pa.types.is_duration(col.type):
                    col = col.cast(pa.int64())
                cols[name] = col.to_pylist()
            for i in range(rb.num_rows):
                row = {name: values[i] for name, values in cols.items()}
                row["static"] = chunk.is_static
                out[chunk.entity_path].append(row)
        for rows in out.values():
            rows.sort(key=lambda r: r["rerun.controls.RowId"])
        return dict(out)

    reader = RrdReader(path)
    (recording,) = reader.recordings()
    assert recording.application_id == rerun_sink.APPLICATION_ID
    blueprints = reader.blueprints()
    assert blueprints, "the view sent no blueprint"
    # The view sends its blueprint again when vehicles appear, each time a new blueprint store: the last sent counts.
    stores = [rows_of(RrdReader(path).stream(store=b)) for b in blueprints]
    latest = max(stores, key=lambda rows: max(r["rerun.controls.RowId"] for rs in rows.values() for r in rs))
    return rows_of(reader.stream(store=recording)), latest


_META = {"rerun.controls.RowId", "wall", "t", "seq", "static"}


def messages(rows: list[dict]) -> dict[int, dict]:
    """The rows of a message entity (``/V/<leaf>``, ``AnyValues``) by ``seq``: ``{field: value}`` (a field's batch
    has one value), with the timelines ``t`` (ns) and ``wall``."""
    out = {}
    for r in rows:
        if r["static"]:
            continue
        msg = {k: v[0] for k, v in r.items() if k not in _META and v is not None}
        msg.update(t_ns=r.get("t"), wall=r["wall"])
        out[r.get("seq")] = msg
    return out


def scalars(rows: list[dict]) -> list[list[float]]:
    return [r["Scalars:scalars"] for r in rows if r.get("Scalars:scalars") is not None]


def by_seq(rows: list[dict]) -> dict[int, list[float]]:
    return {r["seq"]: r["Scalars:scalars"] for r in rows if r.get("Scalars:scalars") is not None}


def listening_addresses(port: int) -> set[str]:
    """The local addresses of the LISTEN sockets on ``port`` (/proc/net/tcp and tcp6)."""
    out = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            addr, p = local.rsplit(":", 1)
            if state == "0A" and int(p, 16) == port:
                out.add(addr)
    return out


# ------------------------------------------------------------------------------------------------------------------
# One run shared by the tests of the module


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    work = tmp_path_factory.mktemp("view-rerun")
    svc = ServiceProcess(prefix=PREFIX)
    client = svc.client()
    view = saver = None
    view_log = work / "view.log"
    try:
        svc.wait_ready(client)
        estimates, truths, rejected = [], [], []
        lock = threading.Lock()

        def keep(into):
            def cb(msg):
                with lock:
                    into.append(msg)
            return cb

        subs = [client.subscribe_estimates(keep(estimates)), client.subscribe_truth(keep(truths)),
                client.subscribe_rejections(keep(rejected))]
        client.health()

        web, grpc = free_port(), free_port()
        script = Path(sys.executable).parent / "attitude-view"
        with open(view_log, "wb") as log:
            view = subprocess.Popen(
                [str(script), "--rerun", "--connect", svc.endpoint, "--prefix", PREFIX, "--max-rate", "0",
                 "--republish", "0.25", "--web-port", str(web), "--grpc-port", str(grpc)],
                stdout=log, stderr=subprocess.STDOUT,
            )
        wait_until(lambda: "web viewer on" in view_log.read_text(errors="replace") or view.poll() is not None, 30,
                   "the view's servers")
        assert view.poll() is None, view_log.read_text()
        url = re.search(r"web viewer on (http://\S+) ", view_log.read_text()).group(1)
        listening = {"web": listening_addresses(web), "grpc": listening_addresses(grpc)}
        with urllib.request.urlopen(url, timeout=10) as r:
            index = r.read().decode()
        with urllib.request.urlopen(f"http://127.0.0.1:{web}/re_viewer_bg.wasm", timeout=30) as r:
            wasm = r.read()

        # A client of the gRPC server, from the start of the recording (the server keeps it for late clients).
        rrd = work / "view.rrd"
        with open(work / "saver.log", "wb") as log:
            saver = subprocess.Popen(
                [str(rerun_sink.rerun_cli()), f"rerun+http://127.0.0.1:{grpc}/proxy", "--save", str(rrd),
                 "--bind", "127.0.0.1", "--port", str(free_port())],
                stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
            )

        for v in VEHICLES:
            kind, _, fid = FILTERS[v].partition(":")
            client.reset(v, filter=kind, **({"fiducial": fid, "particles": PARTICLES} if kind == "qpf" else {}),
                         **({"fiducial": fid} if kind == "usque" else {}), q=(1, 0, 0, 0), t=0.0)
        sim = subprocess.run(
            [str(BIN), "simulate", "--scenario", "star-tracker", "--duration", str(DURATION_S), "--speed", "0",
             "--vehicles", str(len(VEHICLES)), "--filters", ",".join(FILTERS[v] for v in VEHICLES),
             "--particles", str(PARTICLES), "--prefix", PREFIX, "--connect", svc.endpoint],
            capture_output=True, text=True, timeout=120,
        )
        assert sim.returncode == 0, sim.stderr
        last = {}

        def all_done():
            last.update({v: client.get_state(v)["t"] for v in VEHICLES})
            return all(t == DURATION_S for t in last.values())

        # (Once a fixture timed out here with nothing to show why: the vehicles' times, the simulation's and the
        # service's logs go with the failure.)
        deadline = time.monotonic() + 30
        while not all_done():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after 30 s waiting for the last estimates: t per vehicle {last} (of "
                            f"{DURATION_S}); simulate said {sim.stdout[-1500:]!r} {sim.stderr[-1500:]!r}; "
                            f"the service's log ends {svc.log()[-3000:]!r}")
            time.sleep(0.01)
        final = {v: client.get_state(v) for v in VEHICLES}

        # Two bad inputs for sc4: a malformed gyro sample and one older than what it processed.
        client.put_raw("sc4", "gyro", json.dumps({"t": 100.0, "omega": [0.0, 0.0]}))
        client.put_raw("sc4", "gyro", json.dumps({"t": 0.5, "omega": [0.0, 0.0, 0.0]}))
        wait_until(lambda: len(rejected) == 2, 15, "the two rejections at the test's subscription")
        # The view got them at the same time as the test's subscription; then republications of the summary (0.25 s
        # apart). A view behind (a loaded machine) still handles all it received once stopped, before its last summary.
        time.sleep(1.5)
        for s in subs:
            s.undeclare()

        # Stopping the view stops its server; the saving client then closes its file.
        view.send_signal(signal.SIGINT)
        code = view.wait(timeout=30)
        log = view_log.read_text(errors="replace")
        assert code == 0 and "Traceback" not in log and "not shown" not in log, log
        saver.wait(timeout=30)
        assert rrd.exists(), (work / "saver.log").read_text()
        recording, blueprint = read_rrd(rrd)
        with lock:
            yield {
                "estimates": list(estimates), "truths": list(truths), "final": final, "recording": recording,
                "blueprint": blueprint, "listening": listening, "index": index, "wasm": wasm, "url": url,
                "ports": (web, grpc),
            }
    finally:
        for proc in (view, saver):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait()
        client.close()
        svc.stop()


def test_the_servers_listen_on_the_loopback_and_serve_the_web_viewer(run):
    web, grpc = run["ports"]
    assert run["listening"] == {"web": {"0100007F"}, "grpc": {"0100007F"}}, run["listening"]  # 127.0.0.1 only
    assert run["url"] == rerun_sink.viewer_url(web, grpc)
    assert f"url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{grpc}%2Fproxy" in run["url"]
    assert "re_viewer" in run["index"]
    assert run["wasm"][:4] == b"\0asm" and len(run["wasm"]) > 1_000_000


def test_the_entities(run):
    rec = run["recording"]
    for v in VEHICLES:
        for leaf in ("attitude", "error", "diagnostics"):
            assert f"/{v}/{leaf}" in rec, (v, leaf)
        for leaf, fields in rerun_sink.PLOTTED.items():
            for field in fields:
                if field == "ess" and not FILTERS[v].startswith("qpf"):
                    continue
                assert f"/{v}/{leaf}/{field}" in rec, (v, leaf, field)
        for sub in ("estimate", "estimate/body", "estimate/axes", "truth", "truth/axes", "label"):
            assert f"/world/{v}/{sub}" in rec, (v, sub)
        # Each message entity has the fields of its Foxglove topic's schema (objects flattened; vehicle, t and seq
        # are the path and the timelines).
        for leaf in ("attitude", "error", "diagnostics"):
            schema = view_module.schemas()[leaf]
            required = set()
            for name in schema["required"]:
                sub = schema["properties"][name]
                if name in ("vehicle", "t", "seq"):
                    continue
                required |= {f"{name}.{k}" for k in sub["required"]} if sub.get("type") == "object" else {name}
            for msg in messages(rec[f"/{v}/{leaf}"]).values():
                assert required <= set(msg), (v, leaf, required - set(msg))
    assert "/summary" in rec and "/world" in rec
    # No rejection for sc1..sc3: their total is zero from the start (every vehicle has its line in the plot).
    for v in ("sc1", "sc2", "sc3"):
        assert [e for e in rec if e.startswith(f"/{v}/rejections")] == [f"/{v}/rejections/total"]
        totals = scalars(rec[f"/{v}/rejections/total"])
        assert len(totals) > 2 and set(map(tuple, totals)) == {(0.0,)}  # repeated with the summary
    # Nothing else: the vehicles' entities, the scene, the summary and the recording's properties.
    others = [e for e in rec if not re.match(r"/(sc[1-4]/|world|summary$|__properties)", e)]
    assert others == []


def test_each_vehicle_shows_the_services_estimates(run):
    rec, final = run["recording"], run["final"]
    est = {(e["vehicle"], e["seq"]): e for e in run["estimates"]}
    for v in VEHICLES:
        shown = messages(rec[f"/{v}/attitude"])
        seqs = list(shown)
        # --max-rate 0: every estimate, in order, each the service's own.
        assert seqs == list(range(seqs[0], seqs[-1] + 1)) and seqs[-1] == final[v]["seq"], seqs
        assert seqs[-1] - seqs[0] >= DURATION_S
        euler, three_plot = by_seq(rec[f"/{v}/attitude/euler_deg"]), by_seq(rec[f"/{v}/attitude/three_sigma_deg"])
        assert list(euler) == seqs and list(three_plot) == seqs
        for s, m in shown.items():
            e = est[(v, s)]
            assert [m[f"q.{k}"] for k in "wxyz"] == [e["q"][k] for k in "wxyz"]
            assert m["t_ns"] == round(e["t"] * 1e9)  # the `t` timeline: the estimate's time
            assert [m[f"sigma_deg.{a}"] for a in "xyz"] == e["sigma_deg"]
            assert [m[f"three_sigma_deg.{a}"] for a in "xyz"] == three_plot[s] == [3.0 * x for x in e["sigma_deg"]]
            yaw, pitch, roll = to_rotation(e["q"]).as_euler("ZYX", degrees=True)
            assert [m[f"euler_deg.{k}"] for k in ("roll", "pitch", "yaw")] == euler[s]
            assert euler[s] == pytest.approx([roll, pitch, yaw], abs=1e-9)
            assert m["filter"] == FILTERS[v]
        last = shown[seqs[-1]]
        assert [last[f"bias_deg_h.{a}"] for a in "xyz"] == pytest.approx(np.degrees(final[v]["bias"]) * 3600.0,
                                                                            rel=1e-12)
        assert last["received"] >= len(seqs)
        # The wall timeline never goes back.
        walls = [m["wall"] for m in shown.values()]
        assert walls == sorted(walls) and abs(walls[-1] / 1e9 - time.time()) < 300


def test_each_error_is_the_estimate_against_the_truth_at_its_time(run):
    rec = run["recording"]
    truth = {(m["vehicle"], m["t"]): m for m in run["truths"]}
    est = {(e["vehicle"], e["seq"]): e for e in run["estimates"]}
    for v in VEHICLES:
        errors = messages(rec[f"/{v}/error"])
        err = by_seq(rec[f"/{v}/error/error_deg"])
        plus, minus = by_seq(rec[f"/{v}/error/plus_3sigma_deg"]), by_seq(rec[f"/{v}/error/minus_3sigma_deg"])
        assert list(err) == list(plus) == list(minus) == list(errors)
        shown = messages(rec[f"/{v}/attitude"])
        # One error per estimate of the simulation (its truth comes first); at t = 0 the resets have one at most.
        assert len([s for s in err if est[(v, s)]["t"] > 0]) == len([s for s in shown if est[(v, s)]["t"] > 0])
        assert len(err) >= DURATION_S
        inside = 0
        for s, m in errors.items():
            e = est[(v, s)]
            q_true = to_rotation(truth[(v, e["t"])]["q"])
            expected = np.degrees(axis_errors_rad(q_true, e["q"]))
            assert err[s] == [m[f"error_deg.{a}"] for a in "xyz"]
            assert err[s] == pytest.approx(expected, abs=1e-9)
            three = [3.0 * x for x in e["sigma_deg"]]
            assert plus[s] == three and minus[s] == [-x for x in three]
            assert m["nees"] == pytest.approx(attitude_nees(q_true, e), rel=1e-9)
            assert m["angle_deg"] == pytest.approx(np.degrees((to_rotation(e["q"]).inv() * q_true).magnitude()),
                                                   abs=1e-9)
            assert m["within_3sigma"] == all(abs(x) <= t for x, t in zip(expected, three))
            assert [m[f"truth_q.{k}"] for k in "wxyz"] == [truth[(v, e["t"])]["q"][k] for k in "wxyz"]
            inside += m["within_3sigma"]
        assert inside >= 0.8 * len(err), (v, inside, len(err))


def test_the_ess_of_the_particle_filters(run):
    rec = run["recording"]
    est = {(e["vehicle"], e["seq"]): e for e in run["estimates"]}
    for v in VEHICLES:
        diags = messages(rec[f"/{v}/diagnostics"])
        assert list(diags) == list(messages(rec[f"/{v}/attitude"]))
        for s, m in diags.items():
            d = est[(v, s)]["diagnostics"]
            assert m["updates"] == d["updates"] and m["propagations"] == d["propagations"]
        if FILTERS[v].startswith("qpf"):
            ess = by_seq(rec[f"/{v}/diagnostics/ess"])
            assert list(ess) == list(diags)
            for s, value in ess.items():
                d = est[(v, s)]["diagnostics"]
                assert value == [d["ess"]] == [diags[s]["ess"]] and 1.0 <= value[0] <= PARTICLES
                assert diags[s]["particles"] == PARTICLES and diags[s]["ess_fraction"] == d["ess"] / PARTICLES
            # The ESS plot names each vehicle's series after it.
            style = [r for r in rec[f"/{v}/diagnostics/ess"] if r["static"]]
            assert style and style[-1]["SeriesLines:names"] == [v]
        else:
            assert f"/{v}/diagnostics/ess" not in rec
            assert not any("ess" in m or "particles" in m for m in diags.values())


def test_rejections_are_counted_by_code(run):
    rec = run["recording"]
    totals = scalars(rec["/sc4/rejections/total"])
    assert totals[0] == [0.0] and totals[-1] == [2.0]
    last = list(messages(rec["/sc4/rejections"]).values())[-1]
    assert last["total"] == 2 and last["by_code.bad_request"] == 1 and last["by_code.out_of_order"] == 1
    assert {k.split(".", 1)[1] for k in last if k.startswith("by_code.")} == set(view_module.REJECTION_CODES)
    assert sum(v for k, v in last.items() if k.startswith("by_code.")) == 2
    assert last["last.code"] in ("bad_request", "out_of_order") and last["last.key"] == f"{PREFIX}/sc4/gyro"
    lines = [r["TextLog:text"][0] for r in rec["/sc4/rejections/last"] if r.get("TextLog:text")]
    assert len(lines) >= 1
    assert re.fullmatch(rf"(bad_request|out_of_order): .+ \({re.escape(PREFIX)}/sc4/gyro\)", lines[-1]), lines


def _last(rows: list[dict], column: str):
    values = [r[column] for r in rows if r.get(column) is not None]
    return values[-1] if values else None


def test_the_3d_scene_holds_each_estimate_and_its_truth(run):
    rec, final = run["recording"], run["final"]
    truth = {(m["vehicle"], m["t"]): m for m in run["truths"]}
    places = set()
    for v in VEHICLES:
        q, qt = final[v]["q"], truth[(v, DURATION_S)]["q"]
        est_rows, truth_rows = rec[f"/world/{v}/estimate"], rec[f"/world/{v}/truth"]
        # Transform3D stores float32: the rotation of the estimate within its rounding.
        got = _last(est_rows, "Transform3D:quaternion")[0]
        assert got == pytest.approx([q[k] for k in "xyzw"], abs=1e-7)
        assert _last(truth_rows, "Transform3D:quaternion")[0] == pytest.approx([qt[k] for k in "xyzw"], abs=1e-7)
        translation = _last(est_rows, "Transform3D:translation")[0]
        assert translation == _last(truth_rows, "Transform3D:translation")[0]
        places.add(tuple(translation))
        body = rec[f"/world/{v}/estimate/body"]
        assert body[0]["static"] and len(body[0]["Boxes3D:half_sizes"]) == 1
        for axes in (rec[f"/world/{v}/estimate/axes"], rec[f"/world/{v}/truth/axes"]):
            assert axes[0]["static"] and len(axes[0]["Arrows3D:vectors"]) == 3
        assert _last(rec[f"/world/{v}/label"], "Points3D:labels")[0].startswith(f"{v}  {FILTERS[v]}")
        # The transforms are the estimates' rotations, a body vector taken to the reference frame.
        r = Rotation.from_quat(got)
        assert r.apply([1.0, 0.0, 0.0]) == pytest.approx(to_rotation(q).apply([1.0, 0.0, 0.0]), abs=1e-6)
    assert len(places) == len(VEHICLES)
    assert _last(rec["/world"], "ViewCoordinates:xyz") is not None


def test_the_summary_has_a_row_per_vehicle(run):
    rec, final = run["recording"], run["final"]
    (text,) = _last(rec["/summary"], "TextDocument:text")
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[1:-1]]
            for line in text.splitlines() if re.match(r"\| sc\d ", line)}
    assert set(rows) == set(VEHICLES)
    for v in VEHICLES:
        vehicle, filt, t, seq, _err, three, _inside, ess, rejected, _hz = rows[v]
        assert filt == FILTERS[v] and float(t) == DURATION_S and int(seq) == final[v]["seq"]
        assert float(three) == pytest.approx(3.0 * max(final[v]["sigma_deg"]), rel=2e-3)
        assert int(rejected) == (2 if v == "sc4" else 0)
        if FILTERS[v].startswith("qpf"):
            assert float(ess) == pytest.approx(final[v]["diagnostics"]["ess"], abs=0.5)
    assert "0 messages dropped" in text


def _views(blueprint: dict[str, list[dict]]) -> dict[str, dict]:
    views = {}
    for entity, rows in blueprint.items():
        m = re.fullmatch(r"/view/([0-9a-f-]+)", entity)
        if m:
            views.setdefault(m.group(1), {}).update(
                name=_last(rows, "ViewBlueprint:display_name")[0], origin=_last(rows, "ViewBlueprint:space_origin")[0],
                kind=_last(rows, "ViewBlueprint:class_identifier")[0])
        m = re.fullmatch(r"/view/([0-9a-f-]+)/ViewContents", entity)
        if m:
            views.setdefault(m.group(1), {})["contents"] = _last(rows, "ViewContents:query")
    return views


def test_the_blueprint_shows_what_the_view_logs(run):
    rec = run["recording"]
    views = {v["name"]: v for v in _views(run["blueprint"]).values()}
    expected = {"attitude", "vehicles", "effective sample size (particle filters)",
                "rejected inputs since the view started"} | {
        f"{v}: attitude error per body axis (deg) and ±3σ" for v in VEHICLES}
    assert set(views) == expected
    assert views["attitude"]["kind"] == "3D" and views["attitude"]["origin"] == "/world"
    for view in views.values():
        for query in view["contents"]:
            path = query.replace("$origin", view["origin"]).rstrip("/")
            if path.endswith("/**"):
                assert any(e == path[:-3] or e.startswith(path[:-3] + "/") for e in rec), (view["name"], query)
            elif "diagnostics/ess" not in path:  # the MEKF and USQUE have none
                assert path in rec, (view["name"], query)
    errors = views["sc1: attitude error per body axis (deg) and ±3σ"]
    assert errors["origin"] == "/sc1/error" and errors["kind"] == "TimeSeries"
    assert sorted(errors["contents"]) == sorted(f"$origin/{f}" for f in ("error_deg", "minus_3sigma_deg",
                                                                        "plus_3sigma_deg"))


def test_write_blueprint_writes_a_blueprint_file(tmp_path):
    out = tmp_path / "view.rbl"
    script = Path(sys.executable).parent / "attitude-view"
    done = subprocess.run([str(script), "--write-blueprint", str(out), "--layout-vehicles", "a,b", "--no-truth"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    reader = RrdReader(out)
    (bp,) = reader.blueprints()
    assert bp.application_id == rerun_sink.APPLICATION_ID and reader.recordings() == []
    names = set()
    for chunk in reader.stream(store=bp):
        rb = chunk.to_record_batch()
        if "ViewBlueprint:display_name" in rb.schema.names:
            names |= {n[0] for n in rb.column("ViewBlueprint:display_name").to_pylist() if n}
    assert {"a: roll, pitch, yaw (deg)", "a: 3σ per body axis (deg)", "b: roll, pitch, yaw (deg)"} <= names


def test_a_taken_port_is_refused_not_shared(tmp_path):
    """Both ports already listened on (another server): the view says which and exits, rather than logging to it."""
    import socket

    taken = []
    for _ in range(2):
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        s.listen()
        taken.append(s)
    try:
        grpc, web = (s.getsockname()[1] for s in taken)
        script = Path(sys.executable).parent / "attitude-view"
        done = subprocess.run(
            [str(script), "--rerun", "--connect", f"tcp/127.0.0.1:{free_port()}", "--wait", "0",
             "--grpc-port", str(grpc), "--web-port", str(web)],
            capture_output=True, text=True, timeout=60, cwd=tmp_path,
        )
    finally:
        for s in taken:
            s.close()
    assert done.returncode == 1, done.stderr
    assert f"port {grpc} on 127.0.0.1 is taken" in done.stderr, done.stderr


def test_a_view_killed_outright_takes_its_server_along(tmp_path):
    """A view that gets SIGKILL cannot stop the `rerun --serve-web` it started: the server dies with it (Linux's
    parent-death signal), so that nothing keeps listening on the view's ports."""
    import socket

    def listening(port: int) -> bool:
        with socket.socket() as s:
            s.settimeout(0.5)
            return s.connect_ex(("127.0.0.1", port)) == 0

    web, grpc = free_port(), free_port()
    script = Path(sys.executable).parent / "attitude-view"
    log = tmp_path / "view.log"
    with open(log, "wb") as out:
        view = subprocess.Popen(
            [str(script), "--rerun", "--connect", f"tcp/127.0.0.1:{free_port()}", "--wait", "0",
             "--grpc-port", str(grpc), "--web-port", str(web)],
            stdout=out, stderr=subprocess.STDOUT, cwd=tmp_path,
        )
    try:
        wait_until(lambda: "web viewer on" in log.read_text(errors="replace") or view.poll() is not None, 30,
                   "the view's servers")
        assert view.poll() is None, log.read_text()
        assert listening(grpc) and listening(web)
        view.kill()
        view.wait(timeout=10)
        wait_until(lambda: not listening(grpc) and not listening(web), 10, "the server to go with the view")
    finally:
        if view.poll() is None:
            view.kill()
            view.wait()
