"""`--ros2`, `--ros-domain-id N` and `--ros-namespace NAME` on `cart2d sim` and `cart2d serve`: the
cart on ROS 2 (cart2d/ros2/, docs/ros2/)."""

from __future__ import annotations

import argparse
import contextlib
import os
from collections.abc import Iterator
from typing import Any

from cart2d.ros2.names import MAX_DOMAIN_ID, domain_problem, namespace_problem, options_from


def _domain_id(text: str) -> int:
    problem = domain_problem(text)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return int(text)


def _namespace(text: str) -> str:
    problem = namespace_problem(text)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return text


def add_ros2_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--ros2",
        action="store_true",
        help="also be a ROS 2 node (cart2d) on DDS: odom, tf, map, scan, camera; cmd_vel, goal_pose, "
        "navigate_to_pose (docs/ros2/README.md)",
    )
    parser.add_argument(
        "--ros-domain-id",
        type=_domain_id,
        metavar="N",
        help=f"the ROS 2 domain (0-{MAX_DOMAIN_ID}; default: ROS_DOMAIN_ID, else 0)",
    )
    parser.add_argument(
        "--ros-namespace",
        type=_namespace,
        metavar="NAME",
        help="the node's namespace (/cart1/odom, frames cart1/odom): several carts on one network",
    )
    parser.add_argument(
        "--ros-base-only",
        action="store_true",
        help="the base for Nav2 or slam_toolbox: odom, tf, scan, camera, cmd_vel; no map, map -> odom, plan "
        "or goals of cart2d's own (docs/ros2/README.md)",
    )


def ros2_problem(args: argparse.Namespace) -> str | None:
    """Why the ROS 2 options cannot be used, in a sentence (before anything starts)."""
    if not args.ros2 and (
        args.ros_domain_id is not None or args.ros_namespace is not None or args.ros_base_only
    ):
        return "--ros-domain-id, --ros-namespace and --ros-base-only need --ros2"
    from_env = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if args.ros2 and args.ros_domain_id is None and from_env and domain_problem(from_env):
        return f"ROS_DOMAIN_ID: {domain_problem(from_env)}"
    return None


@contextlib.contextmanager
def ros2_session(gateway: Any, args: argparse.Namespace) -> Iterator[Any]:
    """The ROS 2 bridge asked for on the command line, with a line saying where it is."""
    if not args.ros2:
        yield None
        return
    from cart2d.ros2.bridge import Bridge  # DDS only when asked for

    options = options_from(args.ros_domain_id, args.ros_namespace, base_only=args.ros_base_only)
    bridge = Bridge(gateway, options).start()
    try:
        print(
            f"ROS 2 node {options.node_namespace.rstrip('/')}/cart2d on domain {options.domain_id} "
            f"({options.discovery} discovery; rmw_cyclonedds_cpp peers: docs/ros2/README.md)",
            flush=True,
        )
        if options.discovery == "subnet":
            print(
                "  on ROS 2, everyone on this network can drive the cart (DDS has no token); "
                "ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST keeps it to this machine (SECURITY.md)",
                flush=True,
            )
        yield bridge
    finally:
        bridge.close()
