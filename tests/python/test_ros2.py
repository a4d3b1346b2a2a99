"""The ROS 2 edge (proto/ros2.md) against an independent rmw_zenoh-style peer (tests/python/ros2_peer.py: eclipse-zenoh,
rosbags' CDR and type hashes, xxhash's GIDs), with the real binary run on the preset config/ros2.json5.

* Three namespaces (/sat1, /sat2, /sat3) publish sensor_msgs/Imu and MagneticField made from the BROAD excerpts;
  each receives /V/imu/data on the exact key of rosbags' type hash, decoded by rosbags, scored against the optical
  truth as broad_replay scores BROAD; stamps, frame ids, the bias-corrected rate, the passed-through specific
  force and the 33-byte attachments are checked sample by sample.
* The liveliness tokens parse as rmw_zenoh's graph cache parses them, with rosbags' hashes.
* The orientation's direction, pinned with known numbers: a static IMU whose true orientation is a given rotation.
* /diagnostics, a Humble publisher (TypeHashNotSupported), and the zenoh-bridge-ros2dds key format.
"""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ros2_peer as rp
from attitude_client.replay import broad_scores, load_trial
from conftest import BIN, ROOT, ServiceProcess, free_port

DATA = ROOT / "tests" / "data" / "broad"
IMU, MAG, DIAG = "sensor_msgs/msg/Imu", "sensor_msgs/msg/MagneticField", "diagnostic_msgs/msg/DiagnosticArray"
#: Samples of each excerpt replayed (28 s at 286 Hz: the end of the opening rest and 13-15 s of movement).
SAMPLES = 8000


@pytest.fixture(scope="module")
def ros_service(tmp_path_factory):
    """The preset file itself (as a user runs it), on a free port."""
    logdir = tmp_path_factory.mktemp("ros2")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    log = open(logdir / "service.log", "wb")
    proc = subprocess.Popen(
        [str(BIN), "serve", "--config", str(ROOT / "config" / "ros2.json5"), "--listen", endpoint],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    peer = rp.Peer(endpoint, name="probe")
    try:
        assert rp.wait_for(
            lambda: any("/NN/%/%/attitude_service" in k for k in rp.liveliness_keys(peer.session)), 20
        ), (logdir / "service.log").read_text(errors="replace")
        yield endpoint, logdir / "service.log"
    finally:
        peer.close()
        proc.terminate()
        proc.wait(timeout=10)
        log.close()


def excerpt(name: str, n: int = SAMPLES) -> dict:
    path = DATA / f"{name}.hdf5"
    assert path.exists(), f"{path} is missing: the committed excerpts (tests/data/broad/README.md) are required"
    trial = load_trial(path, None)
    for k in ("gyr", "acc", "mag", "opt_quat", "movement", "t"):
        trial[k] = trial[k][:n]
    return trial


def replay(peer: rp.Peer, streams: dict[str, dict], t0: dict[str, float], chunk: int = 400) -> dict[str, list]:
    """Publishes each vehicle's samples (Imu, and MagneticField in tesla just before it) on its own publishers,
    paced by the outputs received; returns {vehicle: [(key, cdr, attachment), ...]}."""
    pubs, subs, got = {}, {}, {v: [] for v in streams}
    for v in streams:
        pubs[v] = (peer.publisher(f"/{v}/imu/data_raw", IMU), peer.publisher(f"/{v}/imu/mag", MAG))
        subs[v] = peer.subscribe(f"/{v}/imu/data", IMU)
    time.sleep(0.5)  # (the subscriptions reach the service: its output is sent only to matching subscribers)
    n = max(len(s["gyr"]) for s in streams.values())
    for start in range(0, n, chunk):
        for v, s in streams.items():
            imu_pub, mag_pub = pubs[v]
            for i in range(start, min(start + chunk, len(s["gyr"]))):
                t = t0[v] + s["t"][i]
                mag_pub.put(rp.mag_msg(t, s["mag"][i] * 1e-6, frame=f"{v}_imu"))
                imu_pub.put(rp.imu_msg(t, s["gyr"][i], s["acc"][i], frame=f"{v}_imu"))
        # Stay within a few chunks of the service (its inboxes are bounded).
        for v in streams:
            rp.wait_for(lambda v=v: len(got[v].extend(rp.drain(subs[v])) or got[v]) >= min(start, len(streams[v]["gyr"])) - 2 * chunk, 30)
    for v, s in streams.items():
        want = len(s["gyr"]) - round(0.1 * s["rate_hz"]) - 1
        rp.wait_for(lambda v=v, want=want: len(got[v].extend(rp.drain(subs[v])) or got[v]) >= want, 30)
    return got


def test_three_namespaces_over_rmw_zenoh(ros_service):
    endpoint, log = ros_service
    streams = {
        "sat1": excerpt("16_undisturbed_fast_translation_B_excerpt"),
        "sat2": excerpt("34_disturbed_attached_magnet_3cm_excerpt"),
        "sat3": excerpt("16_undisturbed_fast_translation_B_excerpt"),
    }
    # sat3's stamps are Unix times, as a robot's clock gives them.
    t0 = {"sat1": 0.0, "sat2": 0.0, "sat3": 1_764_000_000.0}
    peer = rp.Peer(endpoint, name="imu_driver")
    try:
        got = replay(peer, streams, t0)
        tokens = [rp.parse_token(k) for k in rp.liveliness_keys(peer.session)]
    finally:
        peer.close()
    imu_hash = rp.type_hash(IMU)
    report = {}
    for v, s in streams.items():
        out = got[v]
        assert len(out) > 0.95 * len(s["gyr"]), (v, len(out), log.read_text(errors="replace")[-3000:])
        # The key carries rosbags' own type hash (the subscription is on it: nothing else would arrive).
        keys = {k for k, _, _ in out}
        assert keys == {f"0/{v}/imu/data/sensor_msgs::msg::dds_::Imu_/{imu_hash}"}, keys
        publisher = [e for e in tokens if e.kind == "MP" and e.topic == f"/{v}/imu/data"]
        assert len(publisher) == 1 and publisher[0].hash == imu_hash, publisher
        gid = rp.gid_of(
            "/".join(
                ["@ros2_lv", "0", publisher[0].zid, publisher[0].nid, publisher[0].eid, "MP", "%", "%",
                 "attitude_service", rp.mangle(publisher[0].topic), publisher[0].type, publisher[0].hash, publisher[0].qos]
            )
        )
        seqs = []
        n = len(s["gyr"])
        q_est, cov = np.full((n, 4), np.nan), np.full((n, 3, 3), np.nan)
        for _, cdr, att in out:
            seq, ts_ns, g = rp.parse_attachment(att)
            assert g == gid and abs(ts_ns - time.time_ns()) < 600e9
            seqs.append(seq)
            m = rp.decode(cdr)
            t = m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 - t0[v]
            i = int(round(t * s["rate_hz"])) - s["first_sample"]
            assert 0 <= i < n and m.header.stamp == rp.stamp(t0[v] + s["t"][i]), (v, t)
            assert m.header.frame_id == f"{v}_imu"
            acc = [m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z]
            assert acc == list(s["acc"][i])
            w = np.array([m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z])
            assert np.abs(w - s["gyr"][i]).max() < 0.02, (w, s["gyr"][i])  # minus a bias of < 1°/s
            o = m.orientation
            q_est[i] = [o.w, o.x, o.y, o.z]
            cov[i] = np.asarray(m.orientation_covariance).reshape(3, 3)
        assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "sequence numbers step by one"
        r = broad_scores(q_est, cov, s["opt_quat"], s["movement"])
        report[v] = r
        assert r["scored"] > 1500, r
        assert r["total_rmse_deg"] < 3.0 and r["inclination_rmse_deg"] < 1.5, (v, r)
        assert r["tilt_in99"] > 0.9 and 0.5 < r["tilt_nees_median"] < 3.0, (v, r)
    print("ROS 2 session, three namespaces:", {v: {k: round(x, 3) for k, x in r.items()} for v, r in report.items()})
    # The same samples at another epoch give the same orientation.
    assert abs(report["sat1"]["total_rmse_deg"] - report["sat3"]["total_rmse_deg"]) < 0.05, report


def test_graph_tokens_parse_as_rmw_zenoh_does(ros_service):
    endpoint, _ = ros_service
    peer = rp.Peer(endpoint, name="graph")
    try:
        pub = peer.publisher("/gsat/imu/data_raw", IMU)
        for i in range(40):
            pub.put(rp.imu_msg(i * 0.01, [0, 0, 0], [0, 0, 9.81]))
        # The vehicle's three tokens (its publisher, its Imu and its MagneticField subscriptions) are
        # declared one after another: wait for all of them, not the first.
        wanted = ("%gsat%imu%data/", "%gsat%imu%data_raw/", "%gsat%imu%mag/")
        assert rp.wait_for(lambda: all(any(w in k for k in rp.liveliness_keys(peer.session)) for w in wanted), 10)
        keys = [k for k in rp.liveliness_keys(peer.session) if f"/{peer.zid}/" not in k]
    finally:
        peer.close()
    parsed = [rp.parse_token(k) for k in keys]  # raises where rmw_zenoh's graph cache would refuse one
    service = {e.zid for e in parsed if e.kind == "NN" and e.node == "attitude_service"}
    assert len(service) == 1, parsed
    entities = [e for e in parsed if e.zid in service]
    nodes = [e for e in entities if e.kind == "NN"]
    assert [(e.namespace, e.node) for e in nodes] == [("/", "attitude_service")], nodes
    by = {(e.kind, e.topic): e for e in entities if e.kind != "NN"}
    assert by[("MP", "/gsat/imu/data")].type == "sensor_msgs::msg::dds_::Imu_"
    assert by[("MP", "/gsat/imu/data")].hash == rp.type_hash(IMU)
    assert by[("MS", "/gsat/imu/data_raw")].hash == rp.type_hash(IMU)
    assert by[("MS", "/gsat/imu/mag")].hash == rp.type_hash(MAG)
    assert by[("MS", "/gsat/imu/mag")].type == "sensor_msgs::msg::dds_::MagneticField_"
    assert by[("MP", "/diagnostics")].hash == rp.type_hash(DIAG)
    node = nodes[0]
    assert all((e.zid, e.nid, e.domain) == (node.zid, node.nid, 0) for e in entities)
    assert len({e.eid for e in entities if e.kind != "NN"}) == len(entities) - 1, "entity ids are unique"


def test_orientation_direction_known_numbers(ros_service):
    """A static IMU whose orientation (body → East-North-Up) is yaw 90°, pitch 20°, roll -10°: gravity and a field
    whose horizontal part points north, seen in the body frame. The output's orientation is that rotation."""
    endpoint, _ = ros_service
    truth = Rotation.from_euler("ZYX", [90, 20, -10], degrees=True)
    acc = truth.inv().apply([0.0, 0.0, 9.81])
    mag_t = truth.inv().apply([0.0, 20e-6, -40e-6])
    peer = rp.Peer(endpoint, name="static")
    try:
        imu = peer.publisher("/known/imu/data_raw", IMU)
        mag = peer.publisher("/known/imu/mag", MAG)
        sub = peer.subscribe("/known/imu/data", IMU)
        time.sleep(0.3)
        for i in range(200):
            mag.put(rp.mag_msg(i * 0.01, mag_t))
            imu.put(rp.imu_msg(i * 0.01, [0, 0, 0], acc))
        out = []
        assert rp.wait_for(lambda: len(out.extend(rp.drain(sub)) or out) >= 180, 20), len(out)
    finally:
        peer.close()
    o = rp.decode(out[-1][1]).orientation
    est = Rotation.from_quat([o.x, o.y, o.z, o.w])  # scipy: scalar-last, body → reference
    err = np.rad2deg((est * truth.inv()).magnitude())
    assert err < 1.0, (err, est.as_euler("ZYX", degrees=True))
    # Body x points north (ENU y), tilted 20° down by the pitch.
    assert np.allclose(est.apply([1, 0, 0]), truth.apply([1, 0, 0]), atol=0.02)


def test_diagnostics_and_humble(ros_service):
    endpoint, _ = ros_service
    peer = rp.Peer(endpoint, name="diag")
    try:
        diag = peer.subscribe("/diagnostics", DIAG)
        out = peer.subscribe("/humble1/imu/data", IMU)
        humble = peer.publisher("/humble1/imu/data_raw", IMU)
        time.sleep(0.3)
        key = peer.key("/humble1/imu/data_raw", IMU, "TypeHashNotSupported")
        for i in range(60):
            humble.put_raw(bytes(rp.TYPESTORE.serialize_cdr(rp.imu_msg(i * 0.01, [0, 0, 0], [0, 0, 9.81]), IMU)), key=key)
        got = []
        assert rp.wait_for(lambda: len(got.extend(rp.drain(out)) or got) >= 40, 10), "a Humble publisher is heard"
        # An array published before the last sample was fused does not have all 60 yet (the
        # period is 1 s): wait for the first that does, then check it.
        arrays = []

        def complete():
            arrays.extend(rp.drain(diag))
            for _, payload, _ in arrays:
                for s in rp.decode(payload, DIAG).status:
                    if s.hardware_id == "humble1" and any(kv.key == "received" and kv.value == "60" for kv in s.values):
                        return True
            return False

        assert rp.wait_for(complete, 5), [[s.hardware_id for s in rp.decode(p, DIAG).status] for _, p, _ in arrays]
    finally:
        peer.close()
    a = rp.decode(arrays[-1][1], DIAG)
    status = {s.hardware_id: s for s in a.status}
    assert status["humble1"].level == 0 and status["humble1"].message == "tracking", status["humble1"]
    values = {kv.key: kv.value for kv in status["humble1"].values}
    assert values["filter"] == "mekf" and int(values["received"]) == 60, values
    assert len(arrays[-1][2]) == 33


def test_bridge_key_format():
    svc = ServiceProcess({"ros2": {"enabled": True, "format": "bridge", "namespace": "robots"}})
    peer = rp.Peer(svc.endpoint, name="bridge")
    try:
        sub = peer.session.declare_subscriber("robots/b1/imu/data", rp.zenoh.handlers.FifoChannel(1024))
        svc.wait_ready(svc.client())
        time.sleep(0.5)
        for i in range(50):
            peer.session.put("robots/b1/imu/data_raw", bytes(rp.TYPESTORE.serialize_cdr(rp.imu_msg(i * 0.01, [0, 0, 0.1], [0, 0, 9.81]), IMU)))
        got = []
        assert rp.wait_for(lambda: len(got.extend(rp.drain(sub)) or got) >= 30, 15), svc.log()
        tokens = rp.liveliness_keys(peer.session)
        bridge_tokens = sorted(
            str(r.ok.key_expr) for r in peer.session.liveliness().get("@/*/@ros2_lv/**", timeout=2.0) if r.ok is not None
        )
    finally:
        peer.close()
        svc.stop()
    assert all(att is None for _, _, att in got), "the bridge's format has no attachment"
    m = rp.decode(got[-1][1])
    assert abs(m.angular_velocity.z - 0.1) < 0.02 and m.linear_acceleration.z == 9.81
    assert not [k for k in tokens if k.startswith("@ros2_lv/") and "attitude_service" in k], "no rmw_zenoh graph"
    # The bridge's announcements instead (zenoh-plugin-ros2dds' liveliness_mgt.rs), so that a bridge makes the
    # outputs' DDS writers: the vehicle's /robots/b1/imu/data and /diagnostics, reliable, volatile, keep-last 64 and
    # 10 (src/ros2/dds.rs: ORIENTATION_DEPTH, DIAGNOSTICS_DEPTH).
    imu_hash, diag_hash = rp.type_hash(IMU), rp.type_hash(DIAG)
    announced = {k.split("/", 2)[2] for k in bridge_tokens if "/@ros2_lv/MP/" in k}
    assert announced == {
        f"@ros2_lv/MP/robots§b1§imu§data/sensor_msgs§msg§Imu/:1:0:0,64:typehash={imu_hash};",
        f"@ros2_lv/MP/diagnostics/diagnostic_msgs§msg§DiagnosticArray/:1:0:0,10:typehash={diag_hash};",
    }, bridge_tokens


def make_bag(path, trial: dict, storage: str, t0: float = 1_764_000_000.0) -> None:
    """A rosbag2 of a BROAD excerpt, written by rosbags: Imu, MagneticField (tesla), the optical truth as
    QuaternionStamped, and the `movement` flag as std_msgs/Bool whenever it changes."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = rp.TYPESTORE
    QuaternionStamped, Bool = ts.types["geometry_msgs/msg/QuaternionStamped"], ts.types["std_msgs/msg/Bool"]
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=8, storage_plugin=plugin) as w:
        c_imu = w.add_connection("/imu/data_raw", IMU, typestore=ts)
        c_mag = w.add_connection("/imu/mag", MAG, typestore=ts)
        c_truth = w.add_connection("/ground_truth/orientation", "geometry_msgs/msg/QuaternionStamped", typestore=ts)
        c_move = w.add_connection("/movement", "std_msgs/msg/Bool", typestore=ts)
        moving = None
        for i in range(len(trial["gyr"])):
            t = t0 + trial["t"][i]
            st = rp.stamp(t)
            ns = st.sec * 1_000_000_000 + st.nanosec
            if trial["movement"][i] != moving:
                moving = bool(trial["movement"][i])
                w.write(c_move, ns, ts.serialize_cdr(Bool(data=moving), "std_msgs/msg/Bool"))
            w.write(c_mag, ns, ts.serialize_cdr(rp.mag_msg(t, trial["mag"][i] * 1e-6), MAG))
            w.write(c_imu, ns, ts.serialize_cdr(rp.imu_msg(t, trial["gyr"][i], trial["acc"][i]), IMU))
            q = trial["opt_quat"][i]
            if np.isfinite(q).all():
                msg = QuaternionStamped(header=rp.Header(stamp=st, frame_id="world"),
                                        quaternion=rp.Quaternion(w=q[0], x=q[1], y=q[2], z=q[3]))
                w.write(c_truth, ns, ts.serialize_cdr(msg, "geometry_msgs/msg/QuaternionStamped"))


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_bag_replay_of_a_broad_trial(ros_service, tmp_path, storage):
    """A BROAD excerpt made into a rosbag2 (by rosbags), replayed by clients/python/bag_replay.py through the
    service, its output bag read back (by rosbags) and scored against the truth topic."""
    from rosbags.rosbag2 import Reader

    endpoint, log = ros_service
    trial = excerpt("16_undisturbed_fast_translation_B_excerpt", 6000)
    bag = tmp_path / f"broad16_{storage}"
    make_bag(bag, trial, storage)
    vehicle = f"bag_{storage}"
    out = subprocess.run(
        [sys.executable, str(ROOT / "clients" / "python" / "bag_replay.py"), str(bag), "--connect", endpoint,
         "--vehicle", vehicle, "--json"],
        capture_output=True, text=True, timeout=300,
    )
    assert out.returncode == 0, out.stderr + log.read_text(errors="replace")[-3000:]
    summary = json.loads(out.stdout.strip().splitlines()[-1])
    print(f"bag replay ({storage}):", json.dumps(summary))
    assert summary["output"] == str(tmp_path / f"broad16_{storage}_attitude") and summary["storage"] == storage
    v = summary["vehicles"][vehicle]
    assert v["samples"] == 6000 and v["estimates"] >= 6000 - round(0.1 * trial["rate_hz"]) - 1, v
    s = v["scores"]
    assert v["truth_topic"] == "/ground_truth/orientation" and s["scored"] > 1000, s
    assert s["total_rmse_deg"] < 3.0 and s["inclination_rmse_deg"] < 1.5 and s["tilt_in99"] > 0.9, s
    with Reader(pathlib.Path(summary["output"])) as r:
        topics = {c.topic: (c.msgtype, c.msgcount) for c in r.connections}
        assert topics == {f"/{vehicle}/imu/data": (IMU, v["estimates"])}, topics
        first = next(r.messages())
        m = rp.decode(bytes(first[2]))
        assert first[1] == m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
