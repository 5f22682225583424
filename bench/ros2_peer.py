"""The ROS 2 side of bench/ros2.py, in a process of its own (its CPU is not the gateway's): a
reader of odom as RViz subscribes, and teleop writing cmd_vel at 10 Hz, forwards and back, each
command's speed unique so that the gateway's side can tell which it acknowledged. Prints one
JSON object at the end: the wall time each odom (by its x, y) arrived and each command was
written.

`python -m bench.ros2_peer DOMAIN SECONDS`."""

from __future__ import annotations

import json
import sys
import time

from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.node import participant

COMMAND_PERIOD_S = 0.1  # teleop_twist_keyboard's repeat rate


def main(argv: list[str]) -> int:
    domain, seconds = int(argv[0]), float(argv[1])
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

    p = participant(domain, "localhost")
    odom = DataReader(p, Topic(p, "rt/odom", t.Odometry), qos.TOOLS["rviz"])
    cmd = DataWriter(p, Topic(p, "rt/cmd_vel", t.Twist), qos.stream())
    received: list[tuple[float, float, float]] = []
    written: list[tuple[float, float]] = []
    began = time.monotonic()
    next_command = began + 1.0  # after discovery
    k = 0
    while time.monotonic() - began < seconds:
        for sample in odom.take(64):
            if isinstance(sample, t.Odometry):
                received.append((time.time(), sample.pose.pose.position.x, sample.pose.pose.position.y))
        if time.monotonic() >= next_command:
            k += 1
            v = (0.1 if k % 2 else -0.1) + k * 1e-6  # to and fro (no wall met), each speed unique
            written.append((time.time(), v))
            cmd.write(t.Twist(t.Vector3(v)))
            next_command += COMMAND_PERIOD_S
        time.sleep(0.002)
    print(json.dumps({"received": received, "written": written}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
