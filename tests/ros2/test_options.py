"""Where the bridge goes on the graph: --ros-domain-id and --ros-namespace over ROS_DOMAIN_ID
and the discovery range of the environment; a bad value is one sentence and exit status 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from cart2d.ros2.names import Ros2Options, cyclone_config, discovery_from_environment, options_from
from tests.support.cli import cart2d, one_sentence


@pytest.mark.parametrize(
    ("env", "expected"),
    [
        ({}, "subnet"),
        ({"ROS_LOCALHOST_ONLY": "1"}, "localhost"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}, "localhost"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"}, "off"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "ROS_LOCALHOST_ONLY": "1"}, "subnet"),
    ],
)
def test_the_discovery_range_is_the_environments(env: dict[str, str], expected: str) -> None:
    assert discovery_from_environment(env) == expected


def test_the_command_line_goes_over_ros_domain_id() -> None:
    assert options_from(None, None, {"ROS_DOMAIN_ID": "7"}) == Ros2Options(7, "", "subnet")
    assert options_from(3, "cart1/", {"ROS_DOMAIN_ID": "7"}) == Ros2Options(3, "/cart1", "subnet")
    assert options_from(None, None, {}).domain_id == 0


def test_localhost_discovery_has_no_multicast_and_this_machine_for_its_peer() -> None:
    config = cyclone_config("localhost")
    assert "<AllowMulticast>false</AllowMulticast>" in config and '<Peer address="localhost"/>' in config
    assert "Peer" not in cyclone_config("off") and "<Tag>" in cyclone_config("off")
    assert "AllowMulticast" not in cyclone_config("subnet")


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--ros2", "--ros-domain-id", "300"], "argument --ros-domain-id: '300' is not a ROS domain id"),
        (["--ros2", "--ros-namespace", "1cart"], "argument --ros-namespace: '1cart' is not a ROS namespace"),
        (["--ros-domain-id", "3"], "--ros-domain-id, --ros-namespace and --ros-base-only need --ros2"),
    ],
)
def test_bad_ros_options_are_one_sentence(tmp_path: Path, args: list[str], words: str) -> None:
    done = cart2d(tmp_path, "sim", "--no-camera", *args)
    assert done.returncode == 2
    line = one_sentence(done.stderr)
    assert words in line, line
    assert not (tmp_path / "settings.json").exists()
