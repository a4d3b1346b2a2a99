"""The ROS 2 edge against a second independent implementation: zenoh-ros2-sdk (PyPI, "ROS 2 over Zenoh without ROS"),
whose publisher and subscriber build rmw_zenoh's keys, liveliness tokens and attachments themselves and compute the
type hashes with their own code from the .msg definitions.

The SDK would fetch the .msg files of ROS 2's interface packages from their git repositories; there is no network
here, so the test gives it the Jazzy definitions of the types involved (written below) in a directory of its own.
Two namespaces publish sensor_msgs/Imu (a static IMU whose true orientation is known) through the SDK's publishers to
the preset service, and the SDK's subscribers, each on its own computed hash, receive /V/imu/data.
"""

from __future__ import annotations

import subprocess
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import BIN, ROOT, free_port

import zenoh_ros2_sdk  # noqa: F401 - pinned in scripts/python-tests.sh: a missing package fails here, loudly

MSGS = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "geometry_msgs/msg/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "sensor_msgs/msg/Imu": (
        "std_msgs/Header header\n"
        "geometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
        "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
        "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n"
    ),
}


@pytest.fixture(scope="module")
def preset_service(tmp_path_factory):
    logdir = tmp_path_factory.mktemp("ros2sdk")
    port = free_port()
    log = open(logdir / "service.log", "wb")
    proc = subprocess.Popen(
        [str(BIN), "serve", "--config", str(ROOT / "config" / "ros2.json5"), "--listen", f"tcp/127.0.0.1:{port}"],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    try:
        time.sleep(1.0)
        yield port, logdir / "service.log"
    finally:
        proc.terminate()
        proc.wait(timeout=10)
        log.close()


def test_zenoh_ros2_sdk_publishes_and_subscribes(preset_service, tmp_path):
    from zenoh_ros2_sdk import ROS2Publisher, ROS2Subscriber
    from zenoh_ros2_sdk.message_registry import get_registry
    from zenoh_ros2_sdk.session import ZenohSession

    port, log = preset_service
    for name, text in MSGS.items():
        path = tmp_path / "msgs" / f"{name}.msg"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    registry = get_registry()
    registry.messages_dir = tmp_path / "msgs"

    truth = {"sdk1": Rotation.from_euler("ZYX", [30, 5, 0], degrees=True),
             "sdk2": Rotation.from_euler("ZYX", [-120, 0, 15], degrees=True)}
    got = {v: [] for v in truth}
    pubs, subs = {}, {}
    try:
        for v in truth:
            subs[v] = ROS2Subscriber(f"/{v}/imu/data", "sensor_msgs/msg/Imu", got[v].append, node_name=f"{v}_listener",
                                     router_port=port)
            pubs[v] = ROS2Publisher(f"/{v}/imu/data_raw", "sensor_msgs/msg/Imu", node_name=f"{v}_driver",
                                    router_port=port)
        types = ZenohSession.get_instance("127.0.0.1", port).store.types
        Header, Time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
        Quaternion, Vector3 = types["geometry_msgs/msg/Quaternion"], types["geometry_msgs/msg/Vector3"]
        time.sleep(0.5)
        # Without a magnetometer the heading starts at the body's own (ENU, the body's x as north at the start):
        # the check is the tilt, which gravity fixes.
        for i in range(150):
            for v, r in truth.items():
                acc = r.inv().apply([0.0, 0.0, 9.81])
                pubs[v].publish(
                    header=Header(stamp=Time(sec=i // 100, nanosec=(i % 100) * 10_000_000), frame_id=f"{v}_imu"),
                    orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
                    orientation_covariance=np.array([-1.0] + [0.0] * 8),
                    angular_velocity=Vector3(x=0.0, y=0.0, z=0.0),
                    angular_velocity_covariance=np.zeros(9),
                    linear_acceleration=Vector3(x=acc[0], y=acc[1], z=acc[2]),
                    linear_acceleration_covariance=np.zeros(9),
                )
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline and not all(len(g) >= 140 for g in got.values()):
            time.sleep(0.05)
    finally:
        for x in (*pubs.values(), *subs.values()):
            x.close()
        ZenohSession.get_instance("127.0.0.1", port).close()
    for v, r in truth.items():
        # Every sample after the 0.1 s alignment (10 samples) has its orientation.
        assert len(got[v]) >= 140, (v, len(got[v]), log.read_text(errors="replace")[-2000:])
        m = max(got[v], key=lambda g: (g.header.stamp.sec, g.header.stamp.nanosec))
        assert m.header.frame_id == f"{v}_imu" and (m.header.stamp.sec, m.header.stamp.nanosec) == (1, 490_000_000)
        o = m.orientation
        est = Rotation.from_quat([o.x, o.y, o.z, o.w])
        # The vertical seen in the body frame (the tilt, whatever the heading), against the truth's.
        tilt = np.rad2deg(np.arccos(np.clip(est.inv().apply([0, 0, 1]) @ r.inv().apply([0, 0, 1]), -1, 1)))
        assert tilt < 0.5, (v, tilt)
        # No magnetometer: north is the body's x at the start (East-North-Up), so the heading is 90° and the
        # pitch and roll are the truth's.
        assert np.allclose(est.as_euler("ZYX", degrees=True), [90, *r.as_euler("ZYX", degrees=True)[1:]], atol=0.5)
