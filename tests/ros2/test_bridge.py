"""The bridge on DDS over a Gateway on the fake firmware (no physics): what a ROS 2 tool with its
QoS receives, what a late joiner gets, the node in ros_discovery_info, and cmd_vel, goal_pose
and initialpose from DDS writers through the gateway; namespaces apart; bad samples dropped."""

from __future__ import annotations

import logging
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from cart2d.gateway import Gateway
from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.bridge import Bridge
from cart2d.ros2.frames import rpy_quaternion, yaw_of
from cart2d.ros2.names import Ros2Options
from cart2d.ros2.node import gid
from cart2d.store import Store
from tests.support.fake_firmware import FakeFirmware
from tests.support.ros2 import Peer, matched, options, samples
from tests.support.ros2_types import ShortTwist
from tests.support.waiting import wait_for


def telemetry(x: float = 0.4, y: float = 0.3, theta: float = 0.5, tick: int = 1000) -> dict[str, Any]:
    return {
        "type": "telemetry", "x": x, "y": y, "theta": theta, "v_left": 0.1, "v_right": 0.2,
        "v_left_target": 0.1, "v_right_target": 0.2, "pwm_left": 100, "pwm_right": 200,
        "v": 0.15, "omega": 0.3, "v_target": 0.15, "omega_target": 0.3, "distance_to_waypoint": 0.0,
        "waypoint_index": 0, "state": 0, "tick": tick, "mode_name": "MANUAL", "flag_names": [],
    }  # fmt: skip


@pytest.fixture
def peer() -> Iterator[Peer]:
    p = Peer()
    yield p
    p.close()


def bridge_on(gateway: Gateway, namespace: str = "") -> Bridge:
    return Bridge(gateway, options(namespace)).start()


@pytest.fixture
def bridge(gateway: Gateway) -> Iterator[Bridge]:
    b = bridge_on(gateway)
    yield b
    b.close()


def test_a_late_joiner_gets_tf_static_and_robot_description(bridge: Bridge, peer: Peer) -> None:
    static = samples(
        peer.reader("rt/tf_static", t.TFMessage, qos.TOOLS["nav2 map"]), lambda got: len(got) >= 1
    )
    frames = {(s.header.frame_id, s.child_frame_id) for s in static[0].transforms}
    assert ("base_footprint", "base_link") in frames and ("camera_link", "camera_optical_frame") in frames
    urdf = samples(peer.reader("rt/robot_description", t.String, qos.latched()), lambda got: len(got) >= 1)
    links = {link.get("name") for link in ET.fromstring(urdf[0].data).iter("link")}
    assert {"base_footprint", "base_link", "camera_link", "left_encoder_wheel"} <= links


@pytest.mark.parametrize("tool", ["ros2 topic echo", "rviz", "nav2 sensor data"])
def test_each_tools_reader_gets_odom_tf_and_joint_states(bridge: Bridge, peer: Peer, tool: str) -> None:
    profile = qos.TOOLS[tool]
    readers = [
        peer.reader("rt/odom", t.Odometry, profile),
        peer.reader("rt/tf", t.TFMessage, profile),
        peer.reader("rt/joint_states", t.JointState, profile),
    ]
    for reader in readers:
        matched(reader)
    bridge.on_message(telemetry(tick=1000))
    bridge.on_message(telemetry(tick=1005))
    odom = samples(readers[0], lambda got: len(got) >= 2)[-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
    assert (odom.pose.pose.position.x, odom.pose.pose.position.y) == (0.4, 0.3)
    assert yaw_of(odom.pose.pose.orientation) == pytest.approx(0.5)
    assert (odom.twist.twist.linear.x, odom.twist.twist.angular.z) == (0.15, 0.3)
    tf = samples(readers[1], lambda got: len(got) >= 2)[-1]
    assert [(s.header.frame_id, s.child_frame_id) for s in tf.transforms][:2] == [
        ("map", "odom"),
        ("odom", "base_footprint"),
    ]
    joints = samples(readers[2], lambda got: len(got) >= 2)[-1]
    assert joints.position[0] == pytest.approx(0.1 * 5 / 125 / 0.021)  # 5 ticks at 0.1 m/s, r 21 mm


def test_the_node_is_in_ros_discovery_info_with_its_endpoints(bridge: Bridge, peer: Peer) -> None:
    reader = peer.reader("ros_discovery_info", t.ParticipantEntitiesInfo, qos.latched())
    info = samples(reader, lambda got: any(s.gid == gid(bridge.node.participant) for s in got))
    ours = next(s for s in info if s.gid == gid(bridge.node.participant))
    (node,) = ours.node_entities_info_seq
    assert (node.node_namespace, node.node_name) == ("/", "cart2d")
    assert gid(bridge.writers.odom) in node.writer_gid_seq
    assert len(node.reader_gid_seq) >= 4  # cmd_vel twice, goal_pose, initialpose


def velocities(cart: FakeFirmware) -> int:
    return cart.requests.count("VELOCITY")


@pytest.mark.parametrize("kind", [t.Twist, t.TwistStamped])
def test_cmd_vel_drives_through_the_gateway(
    bridge: Bridge, peer: Peer, cart: FakeFirmware, kind: type[Any]
) -> None:
    writer = peer.writer("rt/cmd_vel", kind, qos.stream())
    matched(writer)
    twist = t.Twist(t.Vector3(0.2, 0.0, 0.0), t.Vector3(0.0, 0.0, 0.4))
    writer.write(twist if kind is t.Twist else t.TwistStamped(t.Header(), twist))
    wait_for(lambda: velocities(cart) >= 1, 20.0)


def test_a_stop_on_the_api_wins_over_a_stream_of_cmd_vel(
    peer: Peer, gateway: Gateway, cart: FakeFirmware, request: pytest.FixtureRequest
) -> None:
    bridge = Bridge(gateway, options(), command_clock=lambda: 0.0).start()  # one stream: no silence
    request.addfinalizer(bridge.close)
    writer = peer.writer("rt/cmd_vel", t.Twist, qos.stream())
    matched(writer)
    writer.write(t.Twist(t.Vector3(0.2)))
    wait_for(lambda: velocities(cart) >= 1, 20.0)
    gateway.stop()
    before = velocities(cart)
    for _ in range(10):  # teleop goes on sending
        writer.write(t.Twist(t.Vector3(0.2)))
    wait_for(lambda: bridge.inbound.driver.cancelled == 1, 20.0)
    assert velocities(cart) == before
    assert cart.requests[-1] != "VELOCITY"


def test_goal_pose_plans_a_mission_and_initialpose_sets_the_pose(
    bridge: Bridge, peer: Peer, gateway: Gateway, cart: FakeFirmware
) -> None:
    pose_writer = peer.writer("rt/initialpose", t.PoseWithCovarianceStamped, qos.requests())
    goal_writer = peer.writer("rt/goal_pose", t.PoseStamped, qos.requests())
    matched(pose_writer)
    matched(goal_writer)
    where = t.Pose(t.Point(0.6, 0.4, 0.0), rpy_quaternion(0.0, 0.0, 1.0))
    pose_writer.write(t.PoseWithCovarianceStamped(t.Header(frame_id="map"), t.PoseWithCovariance(where)))
    wait_for(lambda: cart.pose[:2] == [0.6, 0.4], 20.0)
    assert cart.pose[2] == pytest.approx(1.0)
    goal = t.PoseStamped(t.Header(frame_id="map"), t.Pose(t.Point(1.4, 1.2, 0.0)))
    goal_writer.write(goal)
    wait_for(lambda: gateway.mission_view()["state"] == "driving", 20.0)
    assert gateway.mission_view()["goal"] == [1.4, 1.2]
    assert cart.path[-1] == pytest.approx((1.4, 1.2))


def test_samples_that_are_no_pose_or_speed_are_dropped_with_a_line(
    bridge: Bridge, peer: Peer, gateway: Gateway, cart: FakeFirmware, caplog: pytest.LogCaptureFixture
) -> None:
    goal_writer = peer.writer("rt/goal_pose", t.PoseStamped, qos.requests())
    cmd_writer = peer.writer("rt/cmd_vel", t.Twist, qos.stream())
    matched(goal_writer)
    matched(cmd_writer)
    goal_writer.write(t.PoseStamped(t.Header(frame_id="map"), t.Pose(t.Point(math.nan, 1.0, 0.0))))
    goal_writer.write(t.PoseStamped(t.Header(frame_id="base_link"), t.Pose(t.Point(1.0, 1.0, 0.0))))
    goal_writer.write(t.PoseStamped(t.Header(frame_id="map"), t.Pose(orientation=t.Quaternion(0, 0, 0, 7.0))))
    cmd_writer.write(t.Twist(t.Vector3(math.inf)))
    wait_for(lambda: caplog.text.count("dropped") >= 4, 20.0)
    assert "VELOCITY" not in cart.requests and gateway.mission_view()["state"] == "idle"


def test_a_twist_of_another_layout_changes_nothing(bridge: Bridge, peer: Peer, cart: FakeFirmware) -> None:
    writer = peer.writer("rt/cmd_vel", ShortTwist, qos.stream())
    for _ in range(5):
        writer.write(ShortTwist(0.3))
    proper = peer.writer("rt/cmd_vel", t.Twist, qos.stream())
    matched(proper)
    proper.write(t.Twist(t.Vector3(0.1)))
    wait_for(lambda: bridge.inbound.driver.sent >= 1, 20.0)
    assert velocities(cart) == 1  # the proper one only
    # Cyclone's type check (XTypes) matches no reader of Twist with it: its samples never arrive
    assert writer.get_matched_subscriptions() == []


def test_two_namespaces_do_not_hear_each_other(gateway: Gateway, tmp_path: Path, peer: Peer) -> None:
    other_cart = FakeFirmware()
    other = Gateway(other_cart, Store(tmp_path / "other"), Store(tmp_path / "other").load())
    one, two = bridge_on(gateway, "/cart1"), bridge_on(other, "/cart2")
    try:
        odom = peer.reader("rt/cart2/odom", t.Odometry, qos.TOOLS["rviz"])
        matched(odom)
        one.on_message(telemetry(x=1.0))
        two.on_message(telemetry(x=2.0))
        got = samples(odom, lambda got: len(got) >= 1)
        assert {s.pose.pose.position.x for s in got} == {2.0}
        assert got[0].header.frame_id == "cart2/odom" and got[0].child_frame_id == "cart2/base_footprint"
        writer = peer.writer("rt/cart2/cmd_vel", t.Twist, qos.stream())
        matched(writer)
        writer.write(t.Twist(t.Vector3(0.1)))
        wait_for(lambda: "VELOCITY" in other_cart.requests, 20.0)
        assert one.inbound.driver.sent == 0
    finally:
        one.close()
        two.close()
        other.close()


def test_options_prefix_frames_but_the_map() -> None:
    o = Ros2Options(namespace="/cart1")
    assert (o.frame("odom"), o.frame("map"), o.topic("odom"), o.request("stop")) == (
        "cart1/odom",
        "map",
        "rt/cart1/odom",
        "rq/cart1/stopRequest",
    )


def test_a_late_joiner_gets_the_map_and_later_its_changes(
    bridge: Bridge, gateway: Gateway, peer: Peer
) -> None:
    reader = peer.reader("rt/map", t.OccupancyGrid, qos.TOOLS["nav2 map"])
    first = samples(reader, lambda got: len(got) >= 1)[-1]
    assert first.info.width == 46  # the 2.3 m arena at 0.05 m
    gateway.set_obstacle(1.0, 1.0, True)
    changed = samples(reader, lambda got: len(got) >= 1)[-1]
    assert sum(1 for v in bytes(changed.data) if v == 100) > sum(1 for v in bytes(first.data) if v == 100)


def test_the_camera_is_a_scan_and_the_log_is_rosout(bridge: Bridge, peer: Peer) -> None:
    scan = peer.reader("rt/scan", t.LaserScan, qos.TOOLS["nav2 sensor data"])
    rosout = peer.reader("rt/rosout", t.Log, qos.rosout())
    matched(scan)
    matched(rosout)
    bridge.on_message(telemetry(x=0.5, y=0.5, theta=0.0))
    bridge.on_message({"type": "camera", "t": 1.0, "fov": [[1.5, 0.0], [1.5, 1.0]], "hits": [[1.0, 0.5]]})
    got = samples(scan, lambda got: len(got) >= 1)[-1]
    assert min(got.ranges) == pytest.approx(0.5)
    logging.getLogger("cart2d.gateway").warning("a line for rosout")
    lines = samples(rosout, lambda got: any(s.msg == "a line for rosout" for s in got))
    assert any(s.level == 30 and s.name == "cart2d.gateway" for s in lines)


def test_as_nav2s_base_it_leaves_map_to_odom_the_map_and_goals_to_nav2(gateway: Gateway, peer: Peer) -> None:
    bridge = Bridge(gateway, Ros2Options(options().domain_id, "", "localhost", base_only=True)).start()
    try:
        tf = peer.reader("rt/tf", t.TFMessage, qos.TOOLS["rviz"])
        matched(tf)
        bridge.on_message(telemetry())
        got = samples(tf, lambda got: len(got) >= 1)[-1]
        assert ("map", "odom") not in [(s.header.frame_id, s.child_frame_id) for s in got.transforms]
        assert got.transforms[0].child_frame_id == "base_footprint"
        assert bridge.writers.map is None and bridge.action is None
        topics = {reader.topic.name for reader, _ in bridge.inbound.handlers}
        assert topics == {"rt/cmd_vel", "rq/stopRequest", "rq/reset_odometryRequest"}
    finally:
        bridge.close()


def test_the_pose_filters_map_to_odom_goes_out_in_tf_and_its_pose_with_covariance(
    bridge: Bridge, peer: Peer
) -> None:
    tf = peer.reader("rt/tf", t.TFMessage, qos.TOOLS["rviz"])
    pose = peer.reader("rt/pose", t.PoseWithCovarianceStamped, qos.TOOLS["rviz"])
    matched(tf)
    matched(pose)
    covariance = [0.0004, 0.0001, 0.0, 0.0001, 0.0009, 0.0, 0.0, 0.0, 0.0025]
    bridge.on_message(
        {
            "type": "localisation",
            "trusted": True,
            "pose": [1.2, 0.8, 0.3],
            "covariance": covariance,
            "map_to_odom": [0.05, -0.02, 0.1],
            "accepted": 3,
            "doubted": 0,
            "last": "tag 4",
            "markers": [],
        }
    )
    bridge.on_message(telemetry(tick=1000))
    got = samples(tf, lambda got: len(got) >= 1)[-1]
    map_odom = got.transforms[0]
    assert (map_odom.header.frame_id, map_odom.child_frame_id) == ("map", "odom")
    assert (map_odom.transform.translation.x, map_odom.transform.translation.y) == (0.05, -0.02)
    assert yaw_of(map_odom.transform.rotation) == pytest.approx(0.1)
    fix = samples(pose, lambda got: len(got) >= 1)[-1]
    assert fix.header.frame_id == "map"
    assert (fix.pose.pose.position.x, fix.pose.pose.position.y) == (1.2, 0.8)
    assert yaw_of(fix.pose.pose.orientation) == pytest.approx(0.3)
    c = fix.pose.covariance  # ROS's (x, y, z, roll, pitch, yaw), row by row
    assert (c[0], c[1], c[6], c[7], c[35]) == (0.0004, 0.0001, 0.0001, 0.0009, 0.0025)
    assert c[14] == c[21] == c[28] == 0.0  # z, roll, pitch: fixed by the floor
