"""An rmw_zenoh-style ROS 2 peer written for the tests, independent of the service's code: eclipse-zenoh for the
network, rosbags for the CDR and the RIHS01 type hashes, xxhash for the GIDs.

It does what an rmw_zenoh node does (ros2/rmw_zenoh, rmw_zenoh_cpp/src/detail: liveliness_utils.cpp,
attachment_helpers.cpp, rmw_publisher_data.cpp, rmw_subscription_data.cpp, qos.cpp):

* a node's liveliness token ``@ros2_lv/<domain>/<zid>/<nid>/<nid>/NN/<enclave>/<namespace>/<name>`` and one per
  publisher / subscription with the mangled topic name, the DDS type name, the type hash and the QoS;
* publications on ``<domain>/<topic without leading '/'>/<DDS type>/<RIHS01 hash>``, each with the attachment
  (sequence number i64, source timestamp i64 ns, GID as a length-prefixed 16-byte sequence);
* subscriptions on exactly that key, with the type hash of the type it expects: a publisher whose hash differs is
  never heard (this is how rmw_zenoh subscribers behave);
* :func:`parse_token` reads a liveliness token as rmw_zenoh's graph cache does (``Entity::make(keyexpr)``), and
  refuses what it refuses.
"""

from __future__ import annotations

import itertools
import struct
import threading
import time
from dataclasses import dataclass

import numpy as np
import xxhash
import zenoh
from rosbags.typesys import Stores, get_typestore

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
#: rmw_zenoh's default QoS (qos.cpp): keep-last 42, reliable, volatile, infinite durations.
DEFAULT_QOS = {"reliability": 1, "durability": 2, "history": 1, "depth": 42}


def dds_name(typename: str) -> str:
    pkg, sub, name = typename.split("/")
    return f"{pkg}::{sub}::dds_::{name}_"


def type_hash(typename: str) -> str:
    return TYPESTORE.hash_rihs01(typename)


def mangle(name: str) -> str:
    return name.replace("/", "%")


def demangle(name: str) -> str:
    return name.replace("%", "/")


def qos_chunk(reliability: int = 1, durability: int = 2, history: int = 1, depth: int = 10) -> str:
    """qos_to_keyexpr: a value equal to rmw_zenoh's default is left empty."""
    d = DEFAULT_QOS
    r = "" if reliability == d["reliability"] else str(reliability)
    du = "" if durability == d["durability"] else str(durability)
    h = "" if history == d["history"] else str(history)
    de = "" if depth == d["depth"] else str(depth)
    return f"{r}:{du}:{h},{de}:,:,:,,"


def gid_of(token: str) -> bytes:
    """rmw_zenoh's GID: XXH3-128 of the token's key, low 64 bits then high, little-endian."""
    h = xxhash.xxh3_128_intdigest(token.encode())
    return struct.pack("<QQ", h & (2**64 - 1), h >> 64)


def attachment(seq: int, ts_ns: int, gid: bytes) -> bytes:
    return struct.pack("<qq", seq, ts_ns) + bytes([len(gid)]) + gid


def parse_attachment(b: bytes) -> tuple[int, int, bytes]:
    if len(b) != 33 or b[16] != 16:
        raise ValueError(f"not rmw_zenoh's 33-byte attachment: {b.hex()}")
    seq, ts = struct.unpack("<qq", b[:16])
    return seq, ts, b[17:]


@dataclass
class Entity:
    domain: int
    zid: str
    nid: str
    eid: str
    kind: str
    enclave: str
    namespace: str
    node: str
    topic: str | None = None
    type: str | None = None
    hash: str | None = None
    qos: str | None = None


def parse_token(key: str) -> Entity:
    """Entity::make(keyexpr) of liveliness_utils.cpp: raises ValueError where it returns nullptr."""
    parts = key.split("/")
    if len(parts) < 9 or any(p == "" for p in parts):
        raise ValueError(f"invalid liveliness token ({len(parts)} parts, or an empty one): {key}")
    if parts[0] != "@ros2_lv":
        raise ValueError(f"invalid admin space: {key}")
    kind = parts[5]
    if kind not in ("NN", "MP", "MS", "SS", "SC"):
        raise ValueError(f"invalid entity {kind}: {key}")
    e = Entity(int(parts[1]), parts[2], parts[3], parts[4], kind, demangle(parts[6]), demangle(parts[7]), demangle(parts[8]))
    if kind != "NN":
        if len(parts) < 13:
            raise ValueError(f"token of a non-node entity without its topic: {key}")
        q = parts[12].split(":")
        if len(q) < 6 or len(q[2].split(",")) < 2 or len(q[3].split(",")) < 2 or len(q[4].split(",")) < 2 or len(q[5].split(",")) < 3:
            raise ValueError(f"invalid qos {parts[12]}")
        for v in (q[0], q[1], q[2].split(",")[0], q[5].split(",")[0]):
            if v not in ("", "0", "1", "2", "3", "4"):
                raise ValueError(f"invalid qos value {v!r} in {parts[12]}")
        for v in (q[2].split(",")[1], *q[3].split(","), *q[4].split(","), *q[5].split(",")[1:]):
            if v and not v.isdigit():
                raise ValueError(f"invalid qos number {v!r} in {parts[12]}")
        e.topic, e.type, e.hash, e.qos = demangle(parts[9]), demangle(parts[10]), demangle(parts[11]), parts[12]
    return e


class Peer:
    """One ROS 2 node on its own zenoh session."""

    _ids = itertools.count(1)

    def __init__(self, endpoint: str, name: str = "peer", namespace: str = "/", domain: int = 0):
        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("connect/endpoints", f'["{endpoint}"]')
        conf.insert_json5("scouting/multicast/enabled", "false")
        self.session = zenoh.open(conf)
        self.domain = domain
        self.zid = str(self.session.zid())
        self.name, self.namespace, self.nid = name, namespace, 0
        self.tokens = [
            self.session.liveliness().declare_token(
                f"@ros2_lv/{domain}/{self.zid}/{self.nid}/{self.nid}/NN/%/{mangle(namespace)}/{mangle(name)}"
            )
        ]
        self.subscribers = []

    def _endpoint(self, kind: str, topic: str, typename: str, qos: str) -> str:
        eid = next(self._ids)
        token = (
            f"@ros2_lv/{self.domain}/{self.zid}/{self.nid}/{eid}/{kind}/%/{mangle(self.namespace)}/{mangle(self.name)}/"
            f"{mangle(topic)}/{dds_name(typename)}/{type_hash(typename)}/{qos}"
        )
        self.tokens.append(self.session.liveliness().declare_token(token))
        return token

    def key(self, topic: str, typename: str, hash_: str | None = None) -> str:
        return f"{self.domain}/{topic.strip('/')}/{dds_name(typename)}/{hash_ or type_hash(typename)}"

    def publisher(self, topic: str, typename: str) -> "Publisher":
        token = self._endpoint("MP", topic, typename, qos_chunk(depth=10))
        return Publisher(self, self.key(topic, typename), typename, gid_of(token))

    def subscribe(self, topic: str, typename: str, depth: int = 1 << 16):
        """A FIFO of (key, CDR bytes, attachment bytes) on the topic's exact key (our type hash)."""
        self._endpoint("MS", topic, typename, qos_chunk(reliability=2, depth=5))
        sub = self.session.declare_subscriber(self.key(topic, typename), zenoh.handlers.FifoChannel(depth))
        self.subscribers.append(sub)
        return sub

    def close(self) -> None:
        for t in self.tokens:
            t.undeclare()
        for s in self.subscribers:
            s.undeclare()
        self.session.close()


class Publisher:
    def __init__(self, peer: Peer, key: str, typename: str, gid: bytes):
        self.peer, self.key, self.typename, self.gid = peer, key, typename, gid
        self.seq = 0
        self.pub = peer.session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)

    def put_raw(self, payload: bytes, key: str | None = None) -> None:
        self.seq += 1
        att = attachment(self.seq, time.time_ns(), self.gid)
        if key is None:
            self.pub.put(payload, attachment=att)
        else:
            self.peer.session.put(key, payload, attachment=att)

    def put(self, msg) -> None:
        self.put_raw(bytes(TYPESTORE.serialize_cdr(msg, self.typename)))


def drain(sub) -> list:
    out = []
    while True:
        s = sub.try_recv()
        if s is None:
            return out
        att = s.attachment.to_bytes() if s.attachment is not None else None
        out.append((str(s.key_expr), s.payload.to_bytes(), att))


# ---------------------------------------------------------------------------------------------------------------
# Messages, built with rosbags' types.

T = TYPESTORE.types
Time = T["builtin_interfaces/msg/Time"]
Header = T["std_msgs/msg/Header"]
Quaternion = T["geometry_msgs/msg/Quaternion"]
Vector3 = T["geometry_msgs/msg/Vector3"]
Imu = T["sensor_msgs/msg/Imu"]
MagneticField = T["sensor_msgs/msg/MagneticField"]


def stamp(t: float) -> Time:
    sec = int(np.floor(t))
    ns = int(round((t - sec) * 1e9))
    if ns >= 1_000_000_000:
        sec, ns = sec + 1, ns - 1_000_000_000
    return Time(sec=sec, nanosec=ns)


def imu_msg(t: float, gyr, acc, frame: str = "imu_link", gyr_cov=None, acc_cov=None) -> Imu:
    ocov = np.zeros(9)
    ocov[0] = -1.0  # data_raw: no orientation
    return Imu(
        header=Header(stamp=stamp(t), frame_id=frame),
        orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=ocov,
        angular_velocity=Vector3(x=float(gyr[0]), y=float(gyr[1]), z=float(gyr[2])),
        angular_velocity_covariance=np.asarray(gyr_cov if gyr_cov is not None else np.zeros(9), dtype=float),
        linear_acceleration=Vector3(x=float(acc[0]), y=float(acc[1]), z=float(acc[2])),
        linear_acceleration_covariance=np.asarray(acc_cov if acc_cov is not None else np.zeros(9), dtype=float),
    )


def mag_msg(t: float, tesla, frame: str = "imu_link", cov=None) -> MagneticField:
    return MagneticField(
        header=Header(stamp=stamp(t), frame_id=frame),
        magnetic_field=Vector3(x=float(tesla[0]), y=float(tesla[1]), z=float(tesla[2])),
        magnetic_field_covariance=np.asarray(cov if cov is not None else np.zeros(9), dtype=float),
    )


def decode(payload: bytes, typename: str = "sensor_msgs/msg/Imu"):
    return TYPESTORE.deserialize_cdr(payload, typename)


def wait_for(cond, timeout: float = 20.0, step: float = 0.05) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(step)
    return cond()


def liveliness_keys(session: zenoh.Session, domain: int = 0, timeout: float = 2.0) -> list[str]:
    replies = session.liveliness().get(f"@ros2_lv/{domain}/**", timeout=timeout)
    return sorted(str(r.ok.key_expr) for r in replies if r.ok is not None)


__all__ = ["threading"]
