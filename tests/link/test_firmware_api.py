"""The gateway's view of the firmware, against the real firmware in the simulator."""

from __future__ import annotations

import pytest

from cart2d.link import CommandRefused, Link, firmware, path_stream
from cart2d.params import settings_table
from cart2d.simulation.simulator import Simulator
from cart2d.spec import load_spec
from tests.support.sim import wait_idle


def test_the_built_firmware_is_compatible(link: Link) -> None:
    version = firmware.read_version(link)
    firmware.check_compatible(version)
    assert version.waypoint_capacity == 32 and version.firmware == "0.1.0"


def test_a_firmware_with_another_table_is_refused() -> None:
    other = firmware.Version(1, "0.1.0", 0x1234, 0, 32, len(settings_table()))
    with pytest.raises(firmware.IncompatibleFirmware, match="protocol"):
        firmware.check_compatible(other)


def test_status_in_words_at_power_up(link: Link) -> None:
    status = firmware.read_status(link)
    assert status.mode == "IDLE"
    assert status.settings_source == "defaults (blank EEPROM)"
    assert status.has("SETTINGS_DEFAULTED") and not status.has("MOTORS_ENABLED")
    assert status.loop_overruns == 0 and status.last_error is None


def test_settings_are_read_by_stable_id_with_their_defaults(link: Link) -> None:
    values = {s["name"]: s["value"] for s in firmware.read_settings(link)}
    expected = {s["name"]: s["default"] for s in settings_table()}
    assert values.keys() == expected.keys()
    for name, default in expected.items():
        assert values[name] == pytest.approx(default, rel=1e-6), name
    assert firmware.write_setting(link, 6, 0.3) == pytest.approx(0.3)


def test_a_long_path_is_uploaded_in_frames_and_driven(sim: Simulator, link: Link) -> None:
    points = [(0.05 * (i + 1), 0.0) for i in range(30)] + [(1.5, 0.3)]
    path_stream.upload_path(link, points)
    status = wait_idle(link)
    assert int(status[2]) == len(points)
    assert abs(sim.truth()["x"] - 1.5) < 0.01 and abs(sim.truth()["y"] - 0.3) < 0.01


def test_a_path_over_the_maximum_is_refused_before_anything_moves(link: Link) -> None:
    with pytest.raises(ValueError, match="1 to 65535 points"):
        path_stream.upload_path(link, [(0.0, 0.0)] * 65536)
    with pytest.raises(CommandRefused, match="more waypoints than a path holds"):
        link.call("WAIT_XY_ARRAY", 65536.0)
    assert firmware.read_status(link).mode == "IDLE"


def test_a_path_longer_than_the_window_is_streamed_with_telemetry_off(sim: Simulator, link: Link) -> None:
    # 80 points 2 cm apart (window: 32): with telemetry off the uploader follows STATUS.
    link.call("TELEMETRY", 0.0)
    points = [(0.02 * (i + 1), 0.0) for i in range(80)]
    stream = path_stream.upload_path(link, points)
    assert stream.sending and stream.window == firmware.read_version(link).waypoint_capacity
    status = wait_idle(link)
    assert stream.join(1.0) and not stream.failure and stream.sent == 80
    assert stream.status_reads > 0  # it followed STATUS
    assert int(status[1]) & load_spec().flags["ARRIVED"]
    assert int(status[2]) == 80 and int(status[15]) == 80  # index and received: absolute
    assert abs(sim.truth()["x"] - 1.6) < 0.01
