#!/usr/bin/env python3
"""A ROS 2 node that plays an IMU and prints the orientation the attitude service sends back (docs/ros2.md).

It publishes sensor_msgs/msg/Imu on /<vehicle>/imu/data_raw and sensor_msgs/msg/MagneticField on /<vehicle>/imu/mag
at --rate Hz: a still IMU tilted by --roll and --pitch and turned by --yaw (degrees; the body's orientation in
East-North-Up), in a field of 20 µT north and 40 µT down, stamped with the node's clock (so `use_sim_time` and
a /clock work as for any node), and prints roll, pitch and yaw (degrees) and their 1σ from /<vehicle>/imu/data.

Any ROS 2 (Humble and later) on any middleware the service is on: DDS (the service's format "dds",
config/ros2-dds.json5) or rmw_zenoh (config/ros2.json5). Without a ROS installation:

    python3 -m venv ros && . ros/bin/activate
    pip install ros-kilted-rclpy ros-kilted-sensor-msgs ros-kilted-rmw-fastrtps-cpp
    python3 clients/ros2/imu_quickstart.py --vehicle r1 --seconds 5
"""

from __future__ import annotations

import argparse
import math

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import Imu, MagneticField


def rotate_to_body(roll: float, pitch: float, yaw: float, v: tuple[float, float, float]) -> list[float]:
    """The vector ``v`` given in East-North-Up, seen in the body frame of orientation yaw-pitch-roll (Z-Y-X)."""
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    # R (body → ENU) = Rz(yaw) Ry(pitch) Rx(roll); the body sees Rᵀ v.
    r = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    return [sum(r[j][i] * v[j] for j in range(3)) for i in range(3)]


def euler_deg(q) -> tuple[float, float, float]:
    """Roll, pitch, yaw (Z-Y-X, degrees) of a geometry_msgs/Quaternion."""
    w, x, y, z = q.w, q.x, q.y, q.z
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return math.degrees(roll), math.degrees(pitch), math.degrees(yaw)


class Quickstart(Node):
    def __init__(self, a: argparse.Namespace):
        super().__init__("imu_quickstart")
        self.a = a
        angles = [math.radians(x) for x in (a.roll, a.pitch, a.yaw)]
        self.acc = rotate_to_body(*angles, (0.0, 0.0, 9.81))
        self.mag = rotate_to_body(*angles, (0.0, 20e-6, -40e-6))
        # As most IMU drivers publish (SensorDataQoS); the service reads best effort and reliable alike.
        self.imu_pub = self.create_publisher(Imu, f"/{a.vehicle}/imu/data_raw", qos_profile_sensor_data)
        self.mag_pub = self.create_publisher(MagneticField, f"/{a.vehicle}/imu/mag", qos_profile_sensor_data)
        self.create_subscription(
            Imu, f"/{a.vehicle}/imu/data", self.on_orientation, QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        )
        self.received = 0
        self.last_print = None
        self.create_timer(1.0 / a.rate, self.tick)

    def tick(self) -> None:
        stamp = self.get_clock().now().to_msg()
        m = MagneticField()
        m.header.stamp, m.header.frame_id = stamp, f"{self.a.vehicle}/imu_link"
        m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z = self.mag
        self.mag_pub.publish(m)
        s = Imu()
        s.header.stamp, s.header.frame_id = stamp, f"{self.a.vehicle}/imu_link"
        s.orientation_covariance[0] = -1.0  # REP-145: a raw IMU has no orientation
        s.linear_acceleration.x, s.linear_acceleration.y, s.linear_acceleration.z = self.acc
        self.imu_pub.publish(s)

    def on_orientation(self, m: Imu) -> None:
        self.received += 1
        now = self.get_clock().now().nanoseconds
        if self.last_print is not None and now - self.last_print < 0.5e9:
            return
        self.last_print = now
        r, p, y = euler_deg(m.orientation)
        c = m.orientation_covariance
        s = [math.degrees(math.sqrt(max(c[k], 0.0))) for k in (0, 4, 8)]
        print(
            f"{m.header.frame_id} t={m.header.stamp.sec}.{m.header.stamp.nanosec:09d}: roll {r:7.2f}° pitch {p:7.2f}° "
            f"yaw {y:7.2f}°  1σ {s[0]:.2f}° {s[1]:.2f}° {s[2]:.2f}°",
            flush=True,
        )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vehicle", default="r1", help="the vehicle's namespace (default r1)")
    ap.add_argument("--rate", type=float, default=100.0, help="samples per second (default 100)")
    ap.add_argument("--seconds", type=float, default=0.0, help="stop after this long (default: until Ctrl-C)")
    ap.add_argument("--roll", type=float, default=10.0)
    ap.add_argument("--pitch", type=float, default=-5.0)
    ap.add_argument("--yaw", type=float, default=30.0)
    a = ap.parse_args()
    rclpy.init()
    node = Quickstart(a)
    try:
        if a.seconds > 0:
            end = node.get_clock().now().nanoseconds + a.seconds * 1e9
            while rclpy.ok() and node.get_clock().now().nanoseconds < end:
                rclpy.spin_once(node, timeout_sec=0.1)
        else:
            rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        received = node.received
        node.destroy_node()
        rclpy.try_shutdown()
    print(f"{received} orientations received", flush=True)
    return 0 if received > 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
