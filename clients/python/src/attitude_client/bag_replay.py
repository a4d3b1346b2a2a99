"""attitude-bag-replay: a ROS 2 bag through a running attitude-service over its ROS 2 edge (proto/ros2.md).

    attitude-bag-replay BAG [--connect tcp/127.0.0.1:7447] [--vehicle V] [--truth TOPIC] [--json]

BAG is a rosbag2 directory (sqlite3 or MCAP storage, read by rosbags). Every ``sensor_msgs/msg/Imu`` topic of the
bag is one vehicle (``--vehicle`` names it when there is one; otherwise the topic's first namespace chunk, or
``imu``), and a ``sensor_msgs/msg/MagneticField`` topic in the same namespace goes with it. Their messages are
published, in the bag's order, on ``/<V>/imu/data_raw`` and ``/<V>/imu/mag`` as an rmw_zenoh node does (the
service's preset ``config/ros2.json5`` listens there), paced so the service's inboxes never overflow; the service's
``/<V>/imu/data`` is written into a new bag beside the input (``<BAG>_attitude``, same storage), its log time the
message's header stamp, so both open side by side in Foxglove or PlotJuggler.

A ground-truth orientation (``--truth``, or a topic whose name contains ``truth``: ``geometry_msgs/msg/
QuaternionStamped``, ``PoseStamped`` or ``sensor_msgs/msg/Imu``, Hamilton body → reference) is scored as
``attitude-replay`` scores BROAD (``broad_scores``: total, heading and inclination RMSE over the samples where the
``std_msgs/msg/Bool`` topic ``--movement`` — default: one whose name contains ``movement`` — was last true, or all
of them; with the tilt and heading honesty of the published covariance). The truth at each IMU stamp is the
nearest truth message within half a sample.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import zenoh

from .replay import broad_scores
from .ros2 import TYPESTORE, Node

IMU, MAG = "sensor_msgs/msg/Imu", "sensor_msgs/msg/MagneticField"
TRUTH_TYPES = ("geometry_msgs/msg/QuaternionStamped", "geometry_msgs/msg/PoseStamped", IMU)


def _ns(topic: str) -> str:
    parts = topic.strip("/").split("/")
    return parts[0] if len(parts) > 1 else ""


def _vehicle_id(s: str) -> str:
    v = re.sub(r"[^A-Za-z0-9_-]", "_", s)[:64]
    return v or "imu"


def _stamp_ns(msg) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def _truth_quat(msg, typename: str) -> list[float]:
    if typename == "geometry_msgs/msg/QuaternionStamped":
        q = msg.quaternion
    elif typename == "geometry_msgs/msg/PoseStamped":
        q = msg.pose.orientation
    else:
        q = msg.orientation
    return [q.w, q.x, q.y, q.z]


def read_bag(path: Path, args) -> dict:
    """The bag's IMU streams (per vehicle: Imu and MagneticField connections), truth and movement, in order."""
    from rosbags.rosbag2 import Reader

    with Reader(path) as reader:
        conns = reader.connections
        imus = [c for c in conns if c.msgtype == IMU and (not args.truth or c.topic != args.truth)]
        if not imus:
            raise SystemExit(f"{path}: no {IMU} topic")
        if args.vehicle and len(imus) > 1:
            raise SystemExit(f"--vehicle names one vehicle; the bag has {len(imus)} Imu topics")
        vehicles = {}
        for c in imus:
            v = _vehicle_id(args.vehicle or _ns(c.topic) or "imu")
            if v in vehicles:
                v = _vehicle_id(f"{v}_{c.topic}")
            mags = [m for m in conns if m.msgtype == MAG and _ns(m.topic) == _ns(c.topic)]
            vehicles[v] = {"imu": c, "mag": mags[0] if mags else None}
        truth = [c for c in conns if c.topic == args.truth] if args.truth else [
            c for c in conns if "truth" in c.topic and c.msgtype in TRUTH_TYPES
        ]
        movement = [c for c in conns if c.topic == args.movement] if args.movement else [
            c for c in conns if "movement" in c.topic and c.msgtype == "std_msgs/msg/Bool"
        ]
        wanted = [x["imu"] for x in vehicles.values()] + [x["mag"] for x in vehicles.values() if x["mag"]]
        events, truth_t, truth_q, move_t, move_v = [], [], [], [], []
        for conn, _, raw in reader.messages(connections=wanted + truth[:1] + movement[:1]):
            if truth and conn.id == truth[0].id:
                m = TYPESTORE.deserialize_cdr(raw, conn.msgtype)
                truth_t.append(_stamp_ns(m))
                truth_q.append(_truth_quat(m, conn.msgtype))
            elif movement and conn.id == movement[0].id:
                m = TYPESTORE.deserialize_cdr(raw, conn.msgtype)
                move_t.append(len(events))
                move_v.append(bool(m.data))
            else:
                events.append((conn, bytes(raw)))
    # The input's storage, from its metadata.yaml (rosbag2's own key).
    storage = "sqlite3"
    for line in (path / "metadata.yaml").read_text().splitlines():
        if line.strip().startswith("storage_identifier:"):
            storage = line.split(":", 1)[1].strip().strip("'\"") or storage
    return {
        "vehicles": vehicles,
        "events": events,
        "truth": (np.array(truth_t, dtype=np.int64), np.array(truth_q, dtype=float)) if truth_t else None,
        "truth_topic": truth[0].topic if truth else None,
        "movement": (move_t, move_v) if move_t else None,
        "storage": storage,
    }


def replay(bag: dict, endpoint: str, domain: int, chunk: int, timeout: float) -> dict:
    """Publishes the bag's IMU messages; returns {vehicle: {stamp_ns: CDR of the service's Imu}}."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(conf)
    node = Node(session, "attitude_bag_replay", domain)
    out: dict[str, dict[int, bytes]] = {v: {} for v in bag["vehicles"]}
    sent = {v: 0 for v in bag["vehicles"]}
    try:
        pubs, subs, by_conn = {}, {}, {}
        for v, x in bag["vehicles"].items():
            pubs[v] = node.publisher(f"/{v}/imu/data_raw", IMU)
            by_conn[x["imu"].id] = (v, pubs[v])
            if x["mag"] is not None:
                by_conn[x["mag"].id] = (v, node.publisher(f"/{v}/imu/mag", MAG))
            subs[v] = node.subscribe(f"/{v}/imu/data", IMU)
        time.sleep(0.5)  # (the service sends its output to matching subscribers only)

        def drain() -> None:
            for v, sub in subs.items():
                while (s := sub.try_recv()) is not None:
                    cdr = s.payload.to_bytes()
                    m = TYPESTORE.deserialize_cdr(cdr, IMU)
                    out[v][_stamp_ns(m)] = cdr

        def wait(behind: int, deadline: float) -> None:
            while time.monotonic() < deadline:
                drain()
                if all(len(out[v]) >= sent[v] - behind for v in sent):
                    return
                time.sleep(0.02)

        for i, (conn, raw) in enumerate(bag["events"]):
            v, pub = by_conn[conn.id]
            pub.put_cdr(raw)
            if conn.msgtype == IMU:
                sent[v] += 1
            if i % chunk == chunk - 1:
                wait(2 * chunk, time.monotonic() + timeout)
        # The last samples: all but the ones the pipeline used to align (0.1 s).
        wait(0, time.monotonic() + 3.0)
        drain()
    finally:
        node.close()
        session.close()
    return out


def write_bag(path: Path, storage: str, outputs: dict) -> list[str]:
    from rosbags.rosbag2 import StoragePlugin, Writer

    if path.exists():
        shutil.rmtree(path)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    topics = []
    with Writer(path, version=8, storage_plugin=plugin) as w:
        for v, msgs in outputs.items():
            topic = f"/{v}/imu/data"
            conn = w.add_connection(topic, IMU, typestore=TYPESTORE)
            topics.append(topic)
            for stamp, cdr in sorted(msgs.items()):
                w.write(conn, stamp, cdr)
    return topics


def score(bag: dict, vehicle: str, outputs: dict[int, bytes]) -> dict | None:
    if bag["truth"] is None:
        return None
    truth_t, truth_q = bag["truth"]
    imu_id = bag["vehicles"][vehicle]["imu"].id
    stamps, moving = [], []
    flags_at, flags = bag["movement"] or ([], [])
    j, current = 0, True if not flags_at else False
    for i, (conn, raw) in enumerate(bag["events"]):
        while j < len(flags_at) and flags_at[j] <= i:
            current = flags[j]
            j += 1
        if conn.id == imu_id:
            stamps.append(_stamp_ns(TYPESTORE.deserialize_cdr(raw, IMU)))
            moving.append(current)
    stamps = np.array(stamps, dtype=np.int64)
    n = len(stamps)
    q_est, cov = np.full((n, 4), np.nan), np.full((n, 3, 3), np.nan)
    for i, s in enumerate(stamps):
        cdr = outputs.get(int(s))
        if cdr is not None:
            m = TYPESTORE.deserialize_cdr(cdr, IMU)
            o = m.orientation
            q_est[i] = [o.w, o.x, o.y, o.z]
            cov[i] = np.asarray(m.orientation_covariance, dtype=float).reshape(3, 3)
    # The nearest truth within half a sample interval.
    half = int(np.median(np.diff(stamps)) // 2) if n > 1 else 0
    k = np.clip(np.searchsorted(truth_t, stamps), 1, len(truth_t) - 1) if len(truth_t) > 1 else np.zeros(n, dtype=int)
    if len(truth_t) > 1:
        k = np.where(np.abs(truth_t[k - 1] - stamps) <= np.abs(truth_t[k] - stamps), k - 1, k)
    q_true = truth_q[k].copy()
    q_true[np.abs(truth_t[k] - stamps) > half] = np.nan
    return broad_scores(q_est, cov, q_true, np.array(moving, dtype=bool))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="attitude-bag-replay", description=__doc__.split("\n\n")[0])
    p.add_argument("bag", type=Path, help="rosbag2 directory (sqlite3 or MCAP)")
    p.add_argument("--connect", default="tcp/127.0.0.1:7447", help="zenoh endpoint of the service or a router")
    p.add_argument("--domain", type=int, default=0, help="ROS domain id (service.ros2.domain_id)")
    p.add_argument("--vehicle", help="the vehicle id, when the bag has one Imu topic")
    p.add_argument("--truth", help="ground-truth orientation topic")
    p.add_argument("--movement", help="std_msgs/msg/Bool topic: the samples scored")
    p.add_argument("--output", type=Path, help="the output bag (default: <BAG>_attitude beside the input)")
    p.add_argument("--chunk", type=int, default=500, help="messages published between waits for the service")
    p.add_argument("--timeout", type=float, default=30.0, help="longest wait for the service's output, s")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON line")
    args = p.parse_args(argv)
    bag_path = args.bag.resolve()
    bag = read_bag(bag_path, args)
    outputs = replay(bag, args.connect, args.domain, max(1, args.chunk), args.timeout)
    out_path = args.output or bag_path.with_name(bag_path.name + "_attitude")
    topics = write_bag(out_path, bag["storage"], outputs)
    summary = {"input": str(bag_path), "output": str(out_path), "storage": bag["storage"], "topics": topics, "vehicles": {}}
    for v, x in bag["vehicles"].items():
        n = sum(1 for c, _ in bag["events"] if c.id == x["imu"].id)
        entry = {"imu_topic": x["imu"].topic, "mag_topic": x["mag"].topic if x["mag"] else None, "samples": n,
                 "estimates": len(outputs[v])}
        s = score(bag, v, outputs[v])
        if s is not None:
            entry["truth_topic"] = bag["truth_topic"]
            entry["scores"] = s
        summary["vehicles"][v] = entry
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"{bag_path} → {out_path} ({bag['storage']}): {', '.join(topics)}")
        for v, e in summary["vehicles"].items():
            line = f"  {v}: {e['samples']} samples of {e['imu_topic']}, {e['estimates']} orientations"
            if "scores" in e:
                s = e["scores"]
                line += (f"; vs {e['truth_topic']}: total {s['total_rmse_deg']:.2f}°, heading {s['heading_rmse_deg']:.2f}°,"
                         f" inclination {s['inclination_rmse_deg']:.2f}° over {s['scored']} samples")
            print(line)
    missing = [v for v, e in summary["vehicles"].items() if e["estimates"] == 0]
    if missing:
        print(f"no orientation came back for {missing}: is the service running with service.ros2 enabled?", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
