"""The simulator in lockstep with the gateway's perception, as ArduPilot's SITL keeps its simulator
in step with the flight code: simulated time never runs more than FRAMES_AHEAD camera frames past
the newest frame the gateway's camera feed has handled. Perception runs on the gateway's wall
clock; without the lockstep a busy machine lets the simulated cart drive on while perception
falls behind, and whether it sees a box in time depends on the machine's load (issue 22).

The simulator's side-channel "hold" (sim/README.md, "Lockstep") does the waiting: simulated time
runs, paced as ever, up to the hold and waits there until a handled frame moves it on. A frame
is handled once it has been through the feed's processors: perception took it into its grid,
left it out at rest, or could not use it (perception off, no pose yet). Holds fall where a frame
has just arrived and the next is not yet captured, so no frame is in flight across a wait (a
camera without stamps has its frames' poses looked up by their wall-clock arrival; the simulated
camera's are by their stamps, cart2d/gateway/poses.py).

The firmware waits with the world, but a held simulator still answers the host's requests
(hold.hpp in sim/): the gateway's route checks and replans made while it handles a frame, its
STATUS monitor and path stream never see a frozen firmware. What else must not wait for ever:
- the start: nothing is held until the first frame is handled;
- a camera that stops (or perception stuck on a frame): a hold the simulator has waited at for
  STALL_S of wall time with no frame handled is released until one is (the camera feed itself
  counts a camera lost after as long without a frame);
- the end: closing releases the hold.
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from cart2d.params import robot
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator

if TYPE_CHECKING:
    from cart2d.gateway.camera import CameraFeed, Shown

log = logging.getLogger(__name__)

# How far simulated time may run past the newest frame handled: to the arrival of the frame this
# many periods after it (at 15 fps and 60 ms of latency, 0.19 s: under 10 cm at the cart's top
# speed of 0.5 m/s). One would stop the simulator at every frame; two let it run on while the
# gateway keeps up with the camera, and wait only when it is a frame behind.
FRAMES_AHEAD = 2
ARRIVAL_MARGIN_S = 0.001  # a frame is sent at the physics step (0.25 ms) at or after its arrival
STALL_S = 2.0  # a hold reached with no frame handled for this long is released
POLL_S = 0.05  # how often the lockstep looks for a stall between frames


@dataclass(frozen=True)
class CameraTiming:
    """When frames are captured and arrive, in simulated seconds: frame k at k / fps, + latency."""

    fps: float
    latency_s: float

    @classmethod
    def of_the_simulator(cls) -> CameraTiming:
        """robot.toml's [sim.camera], the simulated camera's settings unless changed."""
        cam = robot()["sim"]["camera"]
        return cls(float(cam["fps"]), float(cam["latency_ms"]) / 1000.0)

    def hold_after(self, stamp_s: float, frames_ahead: int = FRAMES_AHEAD) -> float:
        """Where simulated time waits once the frame captured at stamp_s is handled: just after
        the arrival of the frame `frames_ahead` periods later."""
        k = round(stamp_s * self.fps) + frames_ahead
        return k / self.fps + self.latency_s + ARRIVAL_MARGIN_S


class Lockstep:
    """Holds `sim` at most FRAMES_AHEAD frames past what `feed` has handled, from a thread of its
    own (the feed's thread only notes frames). `report()`: what it cost."""

    def __init__(
        self,
        sim: Simulator,
        feed: CameraFeed,
        timing: CameraTiming | None = None,
        frames_ahead: int = FRAMES_AHEAD,
        stall_s: float = STALL_S,
    ) -> None:
        self.sim, self.feed = sim, feed
        self.timing = timing or CameraTiming.of_the_simulator()
        self.frames_ahead = frames_ahead
        self.stall_s = stall_s
        self._cond = threading.Condition()
        self._closed = False
        self._newest: float | None = None  # capture stamp of the newest frame handled
        self._since = time.monotonic()  # when it was handled
        self._fresh = False  # a frame was handled since the lockstep's thread last looked
        self._sent: float | None = None  # the hold the simulator has
        self._released_for: float | None = None  # the frame after which the hold was released
        self.releases = 0  # holds released with no frame handled for stall_s
        self._wait_at_start = self._wait_s()
        self._unsubscribe = feed.subscribe(self._handled)
        self._thread = threading.Thread(target=self._run, name="lockstep", daemon=True)

    def start(self) -> Lockstep:
        self._thread.start()
        return self

    def close(self) -> None:
        """Stops holding: the simulator runs free again."""
        self._unsubscribe()
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout=5.0)
        with contextlib.suppress(SimulatorError):
            self.sim.hold(None)

    def __enter__(self) -> Lockstep:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def report(self) -> dict[str, Any]:
        """perception_wait_s: wall seconds the simulator waited at holds for the gateway; how far
        ahead it may run (frames, and simulated seconds past a frame's capture); the holds
        released because no frame came."""
        return {
            "perception_wait_s": round(self._wait_s() - self._wait_at_start, 3),
            "frames_ahead": self.frames_ahead,
            "ahead_s": round(self.timing.hold_after(0.0, self.frames_ahead), 3),
            "released_without_frames": self.releases,
        }

    def _handled(self, shown: Shown) -> None:
        """A feed viewer (the feed's thread): the frame has been through every processor."""
        if shown.stamp_s is None or not math.isfinite(shown.stamp_s):
            return  # a camera without stamps cannot be held to
        with self._cond:
            self._newest, self._since, self._fresh = shown.stamp_s, time.monotonic(), True
            self._cond.notify_all()

    def _run(self) -> None:
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._closed or self._fresh, POLL_S)
                if self._closed:
                    return
                newest, since, self._fresh = self._newest, self._since, False
            if newest is None or newest == self._released_for:
                continue  # nothing held before the first frame, nor after a release until the next
            if time.monotonic() - since > self.stall_s and self._sent is not None and self._held():
                self._release(newest)
                continue
            want = self.timing.hold_after(newest, self.frames_ahead)
            if want != self._sent:
                self._hold(want)

    def _hold(self, until_s: float | None) -> None:
        try:
            ack = self.sim.hold(until_s)
        except SimulatorError:
            return  # gone or restarting: asked again at the next look
        log.debug("hold at %s s (simulated time now %.3f s)", until_s, ack["t"])
        self._sent = until_s

    def _release(self, newest: float) -> None:
        held_at = self._sent
        self._hold(None)
        self._released_for = newest
        self.releases += 1
        log.info(
            "the simulator waited at %.3f s for %g s with no camera frame handled: released until the next "
            "(the camera: %s)",
            held_at,
            self.stall_s,
            self.feed.status(),
        )

    def _held(self) -> bool:
        """Whether the simulator waits at the hold now."""
        try:
            held: bool = self.sim.control("stats")["stats"]["hold"]["held"]
        except SimulatorError:
            return False
        return held

    def _wait_s(self) -> float:
        try:
            waited: float = self.sim.control("stats")["stats"]["hold"]["wait_s"]
        except SimulatorError:
            return 0.0
        return waited
