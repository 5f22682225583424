"""A mission's eyes: the simulated ESP32-CAM served at its URLs on free ports, read by the
gateway as a real camera is (cart2d/gateway/camera.py), and perception on its frames
(cart2d/gateway/seeing.py), with the camera calibration a user would have made.

Perception runs in wall-clock time on the gateway, so a mission that sees runs the simulator in
real time (at "max" the cart would cover metres while a frame is processed), and in lockstep with
perception (cart2d/simulation/lockstep.py): simulated time waits while perception is behind, so
what the cart has seen, where it is, does not depend on the machine's load. Without the lockstep
the simulated cart drives on as a real one would behind a slow gateway.
"""

from __future__ import annotations

import contextlib
import shutil
import socket
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cart2d.gateway.camera import CameraFeed
from cart2d.gateway.seeing import SETTLE_TIMEOUT_S
from cart2d.perception.calibration import calibration_path
from cart2d.simulation.camera import SimCameraServer
from cart2d.simulation.lockstep import Lockstep
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator

if TYPE_CHECKING:
    from cart2d.gateway import Gateway


def free_port_pair(host: str = "127.0.0.1", tries: int = 50) -> int:
    """A port P with P + 1 also free: the camera's control port and its stream's."""
    for _ in range(tries):
        with socket.socket() as probe:
            probe.bind((host, 0))
            port = int(probe.getsockname()[1])
        if port >= 65535:
            continue
        with contextlib.suppress(OSError), socket.socket() as a, socket.socket() as b:
            a.bind((host, port))
            b.bind((host, port + 1))
            return port
    raise OSError("no two consecutive free ports for the simulated camera")


@contextlib.contextmanager
def mission_camera(
    gateway: Gateway, sim: Simulator, calibration: Path | None, lockstep: bool = True
) -> Iterator[Lockstep | None]:
    """The simulated camera and perception for the mission's run, with the simulator in lockstep
    with perception unless `lockstep` is false (yields the Lockstep, or None). `calibration`: a
    saved camera calibration (cart2d camera calibrate) to see with; None: the nominal model."""
    if calibration is not None:
        shutil.copyfile(calibration, calibration_path(gateway.store.directory))
    server = SimCameraServer(lambda: sim.control_address, free_port_pair()).start()
    step: Lockstep | None = None
    try:
        feed = CameraFeed.of(server.url, None)
        assert feed is not None  # a base URL always gives a feed
        gateway.use_camera(feed.start())
        if lockstep:
            step = Lockstep(sim, feed).start()
        _wait_until_seeing(gateway)
        yield step
    finally:
        if step is not None:
            step.close()
        gateway.use_camera(None)
        server.stop()


def _wait_until_seeing(gateway: Gateway, frames: int = 3, wall_timeout_s: float = 20.0) -> None:
    """Until perception has seen a few frames and knows their capture times (at most
    SETTLE_TIMEOUT_S more): a user looks before sending the cart. The mission's time starts
    after it: a freshly started gateway's clock settling (about a second, longer on a busy
    machine) is not the mission's, and its first look would otherwise wait for it."""
    deadline = time.monotonic() + wall_timeout_s
    while time.monotonic() < deadline:
        seeing = gateway.seeing
        if seeing is not None and seeing.frames >= frames:
            settle_by = time.monotonic() + SETTLE_TIMEOUT_S
            while not seeing.poses.settled() and time.monotonic() < settle_by:
                time.sleep(0.02)
            return
        time.sleep(0.02)
    raise SimulatorError(f"the simulated camera gave perception no frame in {wall_timeout_s:g} s")


def perception_report(gateway: Gateway, lockstep: Lockstep | None = None) -> dict[str, Any]:
    """What perception did in the mission: frames seen, its calibration, the cells it believed
    occupied at the end (x, y, p); each processed frame's capture stamp (simulated s) and the
    odometry pose it was seen from, the replans frames caused with those frames' stamps, the
    longest the camera was blind while the cart drove, and the lockstep's cost
    (Lockstep.report(), None without it)."""
    seeing = gateway.seeing
    view = gateway.perception_view()
    frames = list(seeing.frame_log) if seeing else []
    causes = list(seeing.replan_causes) if seeing else []
    return {
        "frame_log": [[t, round(x, 4), round(y, 4), round(theta, 4)] for t, (x, y, theta) in frames],
        "replan_frames": [
            {"sim_t": r.sim_t, "reason": r.reason, "outcome": r.outcome, "frame_stamp_s": t}
            for r, t in causes
        ],
        "frames": seeing.frames if seeing else 0,
        "frames_without_pose": seeing.skipped if seeing else 0,
        "frames_left_out_at_rest": seeing.idle_skipped if seeing else 0,
        "calibrated": bool(seeing and seeing.calibration and seeing.calibration.calibrated),
        # the longest the camera took no frame in while a goal was driven (simulated s; the cart
        # stops at robot.toml's camera_blind_s)
        "longest_blind_s": round(gateway.blind_watch.longest_s, 3),
        "resolution_m": view["resolution"],
        "cells": view["cells"],
        "lockstep": lockstep.report() if lockstep is not None else None,
    }
