"""The QoS of the bridge's writers and readers, and of the ROS 2 tools' (tests/ros2/ match them).

A reliable writer matches reliable and best-effort readers alike, and a transient-local one
volatile and transient-local readers: so every writer is reliable, and the latched topics (map,
tf_static, robot_description, the action's status) transient-local with depth 1, as map_server,
the static broadcaster and robot_state_publisher publish them. With a history of depth N a
reliable writer keeps the last N samples and never waits for a slow reader."""

from __future__ import annotations

from cyclonedds.core import Policy, Qos
from cyclonedds.util import duration

RELIABLE = Policy.Reliability.Reliable(duration(seconds=1))


def stream(depth: int = 10) -> Qos:
    """rclcpp's default publisher: reliable, volatile, keep the last `depth`."""
    return Qos(RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(depth))


def latched() -> Qos:
    """map_server's /map, the static broadcaster's /tf_static, robot_state_publisher's description."""
    return Qos(RELIABLE, Policy.Durability.TransientLocal, Policy.History.KeepLast(1))


def rosout() -> Qos:
    """rcl's /rosout: transient-local, the last 1000 lines, each for 10 s."""
    return Qos(
        RELIABLE,
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(1000),
        Policy.Lifespan(duration(seconds=10)),
    )


def commands() -> Qos:
    """cmd_vel's reader: best effort matches every writer (teleop's reliable one, a best-effort
    joystick's), and only the newest command counts."""
    return Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(1))


def requests() -> Qos:
    """rmw's services default (and goal_pose's, initialpose's: RViz's reliable publishers)."""
    return Qos(RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(10))


# The readers of the ROS 2 tools, as each subscribes (tests/ros2/ match the writers with them).
TOOLS = {
    "ros2 topic echo": Qos(RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(10)),
    "rviz": Qos(RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(5)),
    "nav2 sensor data": Qos(
        Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(5)
    ),
    "nav2 map": Qos(RELIABLE, Policy.Durability.TransientLocal, Policy.History.KeepLast(1)),
}
