"""The camera is never silently blind: while perception is on and a mission drives, no camera
frame taken in by perception for robot.toml's [planning] camera_blind_s stops the cart as the
emergency stop does (Gateway.stop), and the mission fails with the reason, "the camera went
blind: ...", which /ws's mission message, the panel's notice and the report carry.

A frame is taken in once perception has put it on its grid (or left it out as the same view at
rest: cart2d/gateway/seeing.py): a camera that sends nothing, frames refused or undecodable, a
frame thread that stopped and frames perception fails on all count as blind. While perception
is still working on a frame it decoded (the replan a frame causes, the planner's lock held by
another replan: up to 0.4 s with both cores busy), the view it acts on is counted as fresh for
up to IN_HAND_S: that is the planner's latency, not the camera's, and a stop would cut the replan
short. The blind time counts only while it is watched (perception on, a mission driving), from
the look that first saw the last count, so a watch that is itself held up errs towards a later
stop, never towards stopping a camera that sees.

The time is the cart's: simulated seconds when the gateway runs the simulator (its truth
messages), so a busy machine that slows the simulator slows the watch with it and frames are
due per simulated second; the monotonic clock on a real cart. The watch looks every POLL_S of
the wall clock.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from cart2d.link import CommandRefused, LinkError

if TYPE_CHECKING:
    from cart2d.gateway.camera import CameraFeed
    from cart2d.gateway.seeing import Seeing

log = logging.getLogger(__name__)

POLL_S = 0.05  # a look at the feed this often: 0.05 s of a 0.5 s limit
IN_HAND_S = 2.0  # a frame perception works on longer than this no longer counts as fresh


class _Mission(Protocol):
    @property
    def state(self) -> str: ...


class Watched(Protocol):
    """What the watch asks of the gateway: its camera and perception, the mission, the stop."""

    @property
    def camera(self) -> CameraFeed | None: ...

    @property
    def seeing(self) -> Seeing | None: ...

    @property
    def mission(self) -> _Mission: ...

    def sees(self) -> bool: ...

    def stop(self, reason: str) -> object: ...


class BlindWatch:
    """Stops the mission of `gateway` when its camera has been blind for the feed's `blind_s`."""

    def __init__(self, gateway: Watched, clock: Callable[[], float | None], poll_s: float = POLL_S) -> None:
        """`clock`: the cart's time in seconds (None while it is not known yet)."""
        self.gateway = gateway
        self.clock = clock
        self.poll_s = poll_s
        self._seeing: Seeing | None = None  # the perception looked at, and its count at the last change
        self._count = 0
        self._since = 0.0  # when (clock) that count was first seen
        self._hand: tuple[int, float] | None = None  # the frame in perception's hands, since when (clock)
        self.longest_s = 0.0  # the longest a driving mission went without a frame (a figure for benches)
        self.stops = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="camera blind watch", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)

    def _run(self) -> None:
        while not self._stop.wait(self.poll_s):
            try:
                self.check()
            except (LinkError, CommandRefused) as exc:  # the mission still drives: tried again next look
                log.warning("the camera went blind and the stop did not get through: %s", exc)

    def check(self) -> str:
        """One look; the reason the mission was stopped for ('' if it was not)."""
        g = self.gateway
        seeing, feed, now = g.seeing, g.camera, self.clock()
        if seeing is None or feed is None or now is None:
            self._seeing = None
            return ""
        count = seeing.frames + seeing.idle_skipped
        watched = g.sees() and g.mission.state == "driving"
        if not watched or seeing is not self._seeing or count != self._count or now < self._since:
            # unwatched, a frame taken in, another camera, a clock that started again (a simulator restart)
            self._seeing, self._count, self._since = seeing, count, now
            return ""
        if self._working(feed.in_hand, now):
            self._since = now
            return ""
        blind_s = now - self._since
        self.longest_s = max(self.longest_s, blind_s)
        if blind_s < feed.blind_s:
            return ""
        reason = f"the camera went blind: no frame taken in for {blind_s:.1f} s ({feed.blindness()})"
        log.warning("%s: stopping the cart", reason)
        g.stop(reason)
        self.stops += 1
        return reason

    def _working(self, in_hand: int | None, now: float) -> bool:
        """Whether perception is working on a frame (`in_hand`, its seq), for at most IN_HAND_S."""
        if in_hand is None:
            self._hand = None
            return False
        if self._hand is None or self._hand[0] != in_hand or now < self._hand[1]:
            self._hand = (in_hand, now)
        return now - self._hand[1] < IN_HAND_S
