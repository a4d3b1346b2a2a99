"""A minimal ROS 2 node over rmw_zenoh's wire format, for the tools of this package (``attitude-bag-replay``): the
keys, the liveliness tokens and the attachment of rmw_zenoh (proto/ros2.md), the CDR and the type hashes from
rosbags. No ROS installation is needed.
"""

from __future__ import annotations

import hashlib
import itertools
import struct
import time

import zenoh

try:
    from rosbags.typesys import Stores, get_typestore
except ImportError as e:  # pragma: no cover - the extra is missing
    raise SystemExit("the ROS 2 tools need rosbags: pip install 'attitude-client[ros2]'") from e

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


def dds_name(typename: str) -> str:
    """``sensor_msgs/msg/Imu`` → ``sensor_msgs::msg::dds_::Imu_``."""
    pkg, sub, name = typename.split("/")
    return f"{pkg}::{sub}::dds_::{name}_"


def topic_key(domain: int, topic: str, typename: str) -> str:
    """rmw_zenoh's key of a topic: ``<domain>/<topic>/<DDS type>/<RIHS01 hash>``."""
    return f"{domain}/{topic.strip('/')}/{dds_name(typename)}/{TYPESTORE.hash_rihs01(typename)}"


class Node:
    """One node: its liveliness token, publishers with rmw_zenoh's 33-byte attachment, subscriptions."""

    def __init__(self, session: zenoh.Session, name: str, domain: int = 0):
        self.session, self.name, self.domain = session, name, domain
        self.zid = str(session.zid())
        self._ids = itertools.count(1)
        self.tokens = [session.liveliness().declare_token(f"@ros2_lv/{domain}/{self.zid}/0/0/NN/%/%/{name}")]

    def _token(self, kind: str, topic: str, typename: str, qos: str) -> str:
        token = (
            f"@ros2_lv/{self.domain}/{self.zid}/0/{next(self._ids)}/{kind}/%/%/{self.name}/{topic.replace('/', '%')}/"
            f"{dds_name(typename)}/{TYPESTORE.hash_rihs01(typename)}/{qos}"
        )
        self.tokens.append(self.session.liveliness().declare_token(token))
        return token

    def publisher(self, topic: str, typename: str) -> "Publisher":
        # Reliable, volatile, keep-last 10 in rmw_zenoh's QoS encoding.
        token = self._token("MP", topic, typename, "::,10:,:,:,,")
        # A GID of 16 bytes unique to the publisher (rmw_zenoh hashes the token with XXH3-128; any unique
        # 16 bytes serve a subscriber).
        gid = hashlib.blake2b(token.encode(), digest_size=16).digest()
        return Publisher(self, topic_key(self.domain, topic, typename), typename, gid)

    def subscribe(self, topic: str, typename: str, depth: int = 1 << 18):
        self._token("MS", topic, typename, "2::,5:,:,:,,")
        return self.session.declare_subscriber(topic_key(self.domain, topic, typename), zenoh.handlers.FifoChannel(depth))

    def close(self) -> None:
        for t in self.tokens:
            t.undeclare()


class Publisher:
    def __init__(self, node: Node, key: str, typename: str, gid: bytes):
        self.typename, self.gid, self.seq = typename, gid, 0
        self.pub = node.session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)

    def put_cdr(self, cdr: bytes) -> None:
        self.seq += 1
        attachment = struct.pack("<qq", self.seq, time.time_ns()) + bytes([16]) + self.gid
        self.pub.put(cdr, attachment=attachment)

    def put(self, msg) -> None:
        self.put_cdr(bytes(TYPESTORE.serialize_cdr(msg, self.typename)))
