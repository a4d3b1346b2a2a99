"""Real ROS 2 nodes for the tests of the service on DDS (tests/python/test_ros2_dds.py): rclpy of ROS 2 Kilted
with Fast DDS (rmw_fastrtps_cpp), from PyPI (`ros-kilted-rclpy`, scripts/python-tests.sh), nothing of ours.

Each `Node` has a context of its own on a given ROS domain (as a separate ROS 2 process would), spun by an
executor thread. Discovery stays on this machine: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (set before rclpy
reads it; the service's plugin is given the same)."""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Sequence

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")

import rclpy  # noqa: E402
from builtin_interfaces.msg import Time  # noqa: E402
from rclpy.context import Context  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import (  # noqa: E402
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from sensor_msgs.msg import Imu, MagneticField  # noqa: E402

#: What a subscriber that must lose nothing asks for: reliable, keep-all.
RELIABLE_ALL = QoSProfile(
    history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE
)
#: rclcpp's and rclpy's default publisher: reliable, keep-last 10.
RELIABLE_10 = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
#: A sensor driver's usual publisher (SensorDataQoS): best effort, keep-last 5.
SENSOR_DATA = qos_profile_sensor_data


def stamp(t: float) -> Time:
    """``t`` seconds as builtin_interfaces/Time, rounded to the nanosecond (as rclpy's Time.to_msg does)."""
    ns = int(round(t * 1e9))
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def seconds(s: Time) -> float:
    return s.sec + s.nanosec * 1e-9


def imu_msg(t: float, gyr: Sequence[float], acc: Sequence[float], frame: str = "imu_link") -> Imu:
    """A raw IMU sample as a driver publishes it (REP-145): no orientation (covariance[0] = -1), the rate and the
    specific force with their covariances."""
    m = Imu()
    m.header.stamp = stamp(t)
    m.header.frame_id = frame
    m.orientation_covariance[0] = -1.0
    m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = (float(x) for x in gyr)
    m.angular_velocity_covariance = [1e-6, 0.0, 0.0, 0.0, 1e-6, 0.0, 0.0, 0.0, 1e-6]
    m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = (float(x) for x in acc)
    m.linear_acceleration_covariance = [1e-3, 0.0, 0.0, 0.0, 1e-3, 0.0, 0.0, 0.0, 1e-3]
    return m


def mag_msg(t: float, tesla: Sequence[float], frame: str = "imu_link") -> MagneticField:
    m = MagneticField()
    m.header.stamp = stamp(t)
    m.header.frame_id = frame
    m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z = (float(x) for x in tesla)
    return m


class Node:
    """One rclpy node in a context of its own on ``domain``, spun by a thread."""

    def __init__(self, name: str, domain: int, namespace: str = ""):
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = rclpy.create_node(name, namespace=namespace, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name=f"spin-{name}", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # noqa: BLE001 (the context was shut down under it)
            pass

    def publisher(self, msg_type, topic: str, qos: QoSProfile = RELIABLE_10):
        return self.node.create_publisher(msg_type, topic, qos)

    def subscribe(
        self, msg_type, topic: str, qos: QoSProfile = RELIABLE_ALL, callback: Callable | None = None
    ) -> list:
        """Subscribes; returns the list the messages are appended to, as ``(receipt perf_counter, message)``."""
        got: list = []
        lock = threading.Lock()

        def on_msg(m) -> None:
            now = time.perf_counter()
            with lock:
                got.append((now, m))
            if callback is not None:
                callback(m)

        #: The rclpy Subscription just made (its get_publisher_count() says whether discovery matched it).
        self.last_subscription = self.node.create_subscription(msg_type, topic, on_msg, qos)
        return got

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)
        self._thread.join(timeout=5)


def wait_for(predicate: Callable[[], bool], timeout: float, interval: float = 0.02) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    return bool(predicate())


# ---------------------------------------------------------------------------------------------------
# As a process of its own (another DDS participant): `echo` and `drive`.


def _echo(domain: int) -> None:
    """Republishes every Imu of /echo/in on /echo/out (reliable, keep-all both ways) until terminated."""
    import signal

    node = Node("echo", domain)
    out = node.publisher(Imu, "/echo/out", RELIABLE_ALL)
    node.node.create_subscription(Imu, "/echo/in", out.publish, RELIABLE_ALL)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    print("ready", flush=True)  # the test's clock for discovery starts here, not at a slow start of Python
    stop.wait()
    node.close()


def _drive(args) -> None:
    """Publishes samples [from, to) of a trial as vehicle V's driver once discovery is done both ways, and writes
    the sample indices of the orientations received back (JSON) to --out."""
    import json

    from attitude_client.replay import load_trial

    trial = load_trial(args.trial, None)
    v, lo, hi = args.vehicle, args.from_, args.to
    node = Node(f"driver_{v}", args.domain)
    imu = node.publisher(Imu, f"/{v}/imu/data_raw", RELIABLE_10)
    mag = node.publisher(MagneticField, f"/{v}/imu/mag", RELIABLE_10)
    out = node.subscribe(Imu, f"/{v}/imu/data", RELIABLE_ALL)
    sub = node.last_subscription
    try:
        if not wait_for(
            lambda: imu.get_subscription_count() > 0 and mag.get_subscription_count() > 0 and sub.get_publisher_count() > 0,
            30,
        ):
            raise SystemExit("discovery did not complete within 30 s")
        rate, first = trial["rate_hz"], trial["first_sample"]
        # Within the orientation writer's history (test_ros2_dds.drive).
        for start in range(lo, hi, 25):
            for i in range(start, min(start + 25, hi)):
                t = float(trial["t"][i])
                mag.publish(mag_msg(t, trial["mag"][i] * 1e-6, frame=f"{v}_imu"))
                imu.publish(imu_msg(t, trial["gyr"][i], trial["acc"][i], frame=f"{v}_imu"))
            wait_for(lambda start=start: len(out) >= start - lo - 32, 30, interval=0.002)
        wait_for(lambda: len(out) >= hi - lo, 30)
        time.sleep(0.2)
        indices = [int(round(seconds(m.header.stamp) * rate)) - first for _, m in out]
    finally:
        node.close()
    args.out.write_text(json.dumps({"indices": indices}))


if __name__ == "__main__":
    import argparse
    import pathlib

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("mode", choices=["echo", "drive"])
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--vehicle")
    ap.add_argument("--trial", type=pathlib.Path)
    ap.add_argument("--from", dest="from_", type=int, default=0)
    ap.add_argument("--to", type=int)
    ap.add_argument("--out", type=pathlib.Path)
    a = ap.parse_args()
    if a.mode == "echo":
        _echo(a.domain)
    else:
        _drive(a)
