"""What the gateway asks of the firmware, in words instead of command codes: compatibility,
status, resets and their causes, settings by stable id, paths of any length streamed into the
waypoint window. Built on a Link."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from cart2d.link.transport import CommandRefused, Link, LinkError, LinkTimeout, MotionCancelled, Priority
from cart2d.params import settings_table
from cart2d.spec import load_spec

# How many (x, y) points one frame carries (31 floats at most: the count or index, then pairs).
POINTS_PER_FRAME = 15
SETTINGS_SOURCES = {0: "eeprom", 1: "defaults (blank EEPROM)", 2: "defaults (corrupt EEPROM)"}


class IncompatibleFirmware(LinkError):
    """The firmware was built from a different protocol table than this gateway."""


@dataclass(frozen=True)
class Version:
    protocol: int
    firmware: str
    dictionary_hash: int
    settings_layout: int
    waypoint_capacity: int
    setting_count: int


@dataclass(frozen=True)
class Status:
    mode: str
    flags: list[str]
    waypoint_index: int
    waypoint_count: int
    loop_overruns: int
    cpu_load_pct: int
    cpu_max_pct: int
    rx_errors: int
    settings_source: str
    eeprom_busy: bool
    uptime_s: float
    last_error: str | None
    reset_cause: list[str]  # why the MCU last restarted (docs/protocol.md, Reset causes)
    boot_count: int  # boots since the MCU's RAM was last lost
    replies_dropped: int
    waypoints_received: int  # points of the path the firmware has received (absolute)

    def has(self, flag: str) -> bool:
        return flag in self.flags

    def path_outcome(self) -> str | None:
        """None while the firmware drives a path; "" once it has arrived; else why it stopped."""
        if self.mode == "PATH":
            return None
        if self.has("ARRIVED"):
            return ""
        if self.has("BUMPER"):
            return "the cart touched something in front: a front switch closed and the firmware stopped it"
        if self.has("STALLED"):
            return "a wheel stalled: the cart is blocked"
        return f"the firmware stopped the path (mode {self.mode})"

    def restarted_since(self, earlier: Status) -> bool:
        """Whether the MCU restarted between `earlier` and this STATUS: its boot count changed
        (a reset that kept the RAM), or its uptime went backwards (one that lost it)."""
        return self.boot_count != earlier.boot_count or self.uptime_s < earlier.uptime_s

    def reset_words(self, trigger_known: bool = False) -> str:
        """Why the MCU last restarted, in words (docs/protocol.md, Reset causes); see
        reset_cause_words for `trigger_known`."""
        return reset_cause_words(self.reset_cause, trigger_known)


# What each reset cause means for someone standing by the cart. WATCHDOG is also how REBOOT
# works, so with REBOOT it is not a hang.
RESET_CAUSE_WORDS = {
    "POWER_ON": "the controller was powered up",
    "EXTERNAL": "the reset button, or the serial port was reopened (a Nano resets when its port opens)",
    "BROWN_OUT": "the controller's supply dipped (brown-out)",
    "WATCHDOG": "the firmware stopped running and the watchdog restarted it",
    "REBOOT": "a REBOOT command restarted the firmware",
}


# Behind the Nano's Optiboot 4.4 the firmware finds MCUSR cleared and tells only what the RAM
# says: a reset that kept it is EXTERNAL and WATCHDOG at once (docs/protocol.md, Reset causes).
BEHIND_BOOTLOADER_WORDS = (
    "a reset that kept the RAM: the reset button, the serial port reopened (a Nano resets when its "
    "port opens), or the watchdog after a hang (behind the Optiboot bootloader the firmware cannot "
    "tell them apart)"
)


# What those flags still say when the host knows what reset the MCU: its trigger is not one of
# the ones they cannot tell apart.
KEPT_RAM_WORDS = "a reset that kept the RAM"
KNOWN_EXTERNAL_WORDS = "an external reset (the RESET pin)"


def reset_cause_words(causes: Sequence[str], trigger_known: bool = False) -> str:
    """The causes in words. `trigger_known`: the host knows what reset the MCU (it asked for the
    restart, or its port's opening reset the Nano), so the triggers the flags cannot tell apart
    (the reset button, the port reopened, a hang) are not listed: only what the flags add."""
    if "REBOOT" in causes:
        causes = [c for c in causes if c != "WATCHDOG"]
    elif "EXTERNAL" in causes and "WATCHDOG" in causes:
        rest = [RESET_CAUSE_WORDS.get(c, c) for c in causes if c not in ("EXTERNAL", "WATCHDOG")]
        return "; ".join([KEPT_RAM_WORDS if trigger_known else BEHIND_BOOTLOADER_WORDS, *rest])
    known = {"EXTERNAL": KNOWN_EXTERNAL_WORDS} if trigger_known else {}
    words = [known.get(cause) or RESET_CAUSE_WORDS.get(cause, cause) for cause in causes]
    return "; ".join(words) or "no cause recorded (a jump to address 0, or a bootloader that kept the flags)"


class ControllerRestarted(LinkError):
    """The MCU restarted while something depended on its state (a path, a calibration run)."""

    def __init__(self, status: Status) -> None:
        super().__init__(f"the controller restarted (boot {status.boot_count}): {status.reset_words()}")
        self.status = status


class ResetWatch:
    """Notices a restart of the MCU between the STATUS replies it is shown. The first one is
    the baseline. Show it the replies of one thread, in the order they were read: replies read
    by several threads may reach it out of order and look like an uptime going backwards."""

    def __init__(self, baseline: Status | None = None) -> None:
        self.last = baseline

    def saw(self, status: Status) -> bool:
        """True if the MCU restarted since the last STATUS shown; `status` becomes the last."""
        restarted = self.last is not None and status.restarted_since(self.last)
        self.last = status
        return restarted

    def check(self, status: Status) -> Status:
        """`status`, or ControllerRestarted if the MCU restarted since the last one."""
        if self.saw(status):
            raise ControllerRestarted(status)
        return status

    def read(self, link: Link) -> Status:
        return self.check(read_status(link))


def wait_path_end(
    link: Link, expired: Callable[[], bool], poll_s: float, watch: ResetWatch | None = None
) -> Status | None:
    """Polls STATUS until the firmware leaves PATH mode and returns that status (its
    path_outcome() says how the path ended); None once expired() says the time is up. With a
    watch, a restart of the MCU raises ControllerRestarted (a reset loses the path)."""
    while True:
        status = read_status(link) if watch is None else watch.read(link)
        if status.path_outcome() is not None:
            return status
        if expired():
            return None
        time.sleep(poll_s)


def flag_names(word: int) -> list[str]:
    return [name for name, bit in load_spec().flags.items() if word & bit]


def mode_name(code: int) -> str:
    """The firmware mode's name from the specification; "mode N" for a code it lacks."""
    return load_spec().modes.get(code, f"mode {code}")


def read_version(link: Link) -> Version:
    protocol, firmware, dictionary, layout, capacity, count = link.call("VERSION")
    fw = int(firmware)
    return Version(
        protocol=int(protocol),
        firmware=f"{fw // 10000}.{fw // 100 % 100}.{fw % 100}",
        dictionary_hash=int(dictionary),
        settings_layout=int(layout),
        waypoint_capacity=int(capacity),
        setting_count=int(count),
    )


# A Nano resets when its port opens and the firmware answers once Optiboot has let it go: ~0.5 s
# when requests come at once, 1.5 s at most (docs/firmware.md, "Start-up time after a reset").
FIRST_ANSWER_S = 10.0


def wait_for_version(link: Link, wait_s: float = FIRST_ANSWER_S) -> Version:
    """VERSION, asked again until the firmware answers or wait_s have passed (then LinkError)."""
    deadline = time.monotonic() + wait_s
    while True:
        try:
            return read_version(link)
        except LinkError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def check_compatible(version: Version) -> None:
    """Refuses a firmware that speaks another protocol table (Klipper's dictionary idea)."""
    spec = load_spec()
    if version.protocol != spec.version or version.dictionary_hash != spec.dictionary_hash:
        raise IncompatibleFirmware(
            f"the firmware speaks protocol {version.protocol} (table {version.dictionary_hash:#06x}), "
            f"this gateway {spec.version} (table {spec.dictionary_hash:#06x}): update one of them"
        )
    if version.setting_count != len(settings_table()):
        raise IncompatibleFirmware("the firmware has a different settings table: update one of them")


def read_status(link: Link) -> Status:
    r = link.call("STATUS")
    spec = load_spec()
    last_error = int(r[11])
    return Status(
        mode=mode_name(int(r[0])),
        flags=flag_names(int(r[1])),
        waypoint_index=int(r[2]),
        waypoint_count=int(r[3]),
        loop_overruns=int(r[4]),
        cpu_load_pct=int(r[5]),
        cpu_max_pct=int(r[6]),
        rx_errors=int(r[7]),
        settings_source=SETTINGS_SOURCES.get(int(r[8]), "unknown"),
        eeprom_busy=bool(r[9]),
        uptime_s=r[10],
        last_error=spec.reasons.get(last_error) if last_error else None,
        reset_cause=[name for name, bit in spec.reset_causes.items() if int(r[12]) & bit],
        boot_count=int(r[13]),
        replies_dropped=int(r[14]),
        waypoints_received=int(r[15]),
    )


def read_settings(link: Link, priority: Priority = Priority.COMMAND) -> list[dict[str, object]]:
    """Every firmware setting with its current value, range and unit (from robot.toml)."""
    out: list[dict[str, object]] = []
    for entry in settings_table():
        out.append({**entry, "value": read_setting(link, entry["id"], priority)})
    return out


def read_setting(link: Link, setting_id: int, priority: Priority = Priority.COMMAND) -> float:
    _, value, _low, _high = link.call("PARAM_GET", setting_id, priority=priority)
    return value


class SettingsCache:
    """The firmware's settings as last read, read again only once they may have changed: after
    any command that may change them (the link's settings_epoch moves), a reopened port or a
    restart of the MCU. One reader fills it at a time, behind every other request; readers that
    come meanwhile wait for it and share what it read."""

    def __init__(self, link: Link) -> None:
        self.link = link
        self._lock = threading.Lock()
        self._values: list[dict[str, object]] | None = None
        self._epoch = -1
        self.fills = 0  # times it read the settings from the firmware

    def read(self) -> list[dict[str, object]]:
        with self._lock:
            epoch = self.link.settings_epoch
            if self._values is not None and self._epoch == epoch:
                return [dict(entry) for entry in self._values]
            values = read_settings(self.link, Priority.BACKGROUND)
            self.fills += 1
            if self.link.settings_epoch == epoch:  # nothing changed them while they were read
                self._values, self._epoch = values, epoch
            return [dict(entry) for entry in values]


def write_setting(link: Link, setting_id: int, value: float) -> float:
    return link.call("PARAM_SET", setting_id, value)[1]


# docs/protocol.md, "Paths and the waypoint window": a path has at most this many points.
MAX_PATH_POINTS = 65535
# How often the stream looks at the cart's progress (the latest telemetry frame), and after how
# long without a frame it reads STATUS instead (telemetry off, or late).
STREAM_POLL_S = 0.005
TELEMETRY_STALE_S = 0.15
STATUS_POLL_S = 0.04

Point = tuple[float, float]


class PathStream:
    """A path of any length streamed into the firmware's waypoint window (docs/protocol.md,
    "Paths and the waypoint window"). start() sends WAIT_XY_ARRAY with the first frame and
    XY_APPEND while the window has room; if points remain, a thread of its own keeps the window
    full as the cart passes waypoints, until every point is sent, the firmware leaves PATH mode,
    the path is replaced, or cancel(). It follows the cart by telemetry's waypoint index and
    mode, and by STATUS when no frame has come for TELEMETRY_STALE_S (telemetry off). Its
    requests go through the link, one outstanding at a time like any other, and belong to the
    stop generation `token` (Link.motion_token(); default: now): a STOP ends the stream, and
    none of its frames follows that STOP."""

    def __init__(self, link: Link, points: Sequence[Point], token: int | None = None) -> None:
        if not 1 <= len(points) <= MAX_PATH_POINTS:
            raise ValueError(f"a path has 1 to {MAX_PATH_POINTS} points, not {len(points)}")
        self.link = link
        self.token = link.motion_token() if token is None else token
        self.points = [(float(x), float(y)) for x, y in points]
        self.sent = 0  # points the firmware has received
        self.index = 0  # the current waypoint, as last seen
        self.window = 0  # the window's size W, learnt from the first reply (0: the path fitted)
        self.appends = 0
        self.status_reads = 0
        self.ended = ""  # why it stopped before every point was sent ("" while running or when done)
        self.failure = ""  # the same when it leaves the cart waiting for points it will not get
        self.done = threading.Event()  # nothing more will be sent
        self._cancelled = threading.Event()
        self._send_lock = threading.Lock()  # held from the cancel check to the append's reply
        self._thread: threading.Thread | None = None

    @property
    def count(self) -> int:
        return len(self.points)

    @property
    def sending(self) -> bool:
        """Points are still to be sent (and the stream has not ended)."""
        return not self.done.is_set()

    def start(self) -> PathStream:
        """Sends the path's beginning; raises CommandRefused, LinkError or MotionCancelled (then
        nothing of it, or only its first frame, reached the firmware: a refused WAIT_XY_ARRAY
        changes nothing)."""
        first = self.points[:POINTS_PER_FRAME]
        reply = self.link.call("WAIT_XY_ARRAY", self.count, *[c for p in first for c in p], token=self.token)
        received, index, room = (int(v) for v in reply)
        self.sent, self.index = received, index
        if received + room < self.count:
            self.window = received + room  # at index 0 the window starts at point 0
        return self._go_on(room)

    def resumed(self, index: int, received: int, token: int | None = None) -> PathStream:
        """A stream of the rest of this path, from the firmware's `index` and `received` on, once
        a START resumed the path that a STOP ended this stream of; its frames belong to `token`."""
        stream = PathStream(self.link, self.points, token)
        stream.sent, stream.index, stream.window = received, index, self.window
        return stream._go_on(stream._room())

    def _go_on(self, room: int) -> PathStream:
        """Fills the window's `room` now; the rest, if any, from a thread of its own."""
        frames_seen = self.link.telemetry_count
        self._fill(room)
        if self.sent >= self.count:
            self.done.set()
        elif not self.done.is_set():
            self._thread = threading.Thread(
                target=self._run, args=(frames_seen,), name="path stream", daemon=True
            )
            self._thread.start()
        return self

    def cancel(self) -> None:
        """Stops streaming: no XY_APPEND is sent once this returns (send it before replacing the
        path: the firmware would take an old append whose index fits for the new path's)."""
        self._cancelled.set()
        with self._send_lock:
            pass
        if not self.done.is_set():
            self._end("cancelled")

    def join(self, timeout_s: float | None = None) -> bool:
        """Waits until nothing more will be sent; True if so."""
        return self.done.wait(timeout_s)

    # -- the thread ------------------------------------------------------------------------------
    @property
    def _batch(self) -> int:
        # Points worth a request of their own: a quarter of the window (8 of 32) keeps at least
        # three quarters of it ahead of the cart with a quarter of the requests of one per point.
        return max(1, self.window // 4)

    def _room(self) -> int:
        base = max(self.index - 1, 0)
        return max(0, min(self.count, base + self.window) - self.sent)

    def _end(self, why: str, failure: bool = False) -> None:
        self.ended = why
        if failure:
            self.failure = why
        self.done.set()

    def _fill(self, room: int) -> None:
        """XY_APPEND frames while the window has room (as the last reply said)."""
        while room > 0 and self.sent < self.count:
            chunk = self.points[self.sent : self.sent + min(room, POINTS_PER_FRAME)]
            with self._send_lock:
                if self._cancelled.is_set():
                    return
                try:
                    reply = self.link.call(
                        "XY_APPEND", self.sent, *[c for p in chunk for c in p], token=self.token
                    )
                except MotionCancelled:
                    self._end("stopped")
                    return
                except CommandRefused as exc:
                    self._end(
                        f"the firmware refused the path's points {self.sent} on ({exc}): "
                        "the path was replaced or changed by another sender",
                        failure=True,
                    )
                    return
                except LinkTimeout:
                    self._resync()
                    return
                except LinkError as exc:
                    self._end(f"the link failed while streaming the path: {exc}", failure=True)
                    return
            self.appends += 1
            received, index, room = (int(v) for v in reply)
            if received != self.sent + len(chunk):
                self._end(f"the firmware holds {received} points, not {self.sent + len(chunk)}", failure=True)
                return
            self.sent, self.index = received, max(self.index, index)

    def _resync(self) -> None:
        """After an XY_APPEND whose reply never came: STATUS tells whether it arrived."""
        try:
            status = read_status(self.link)
        except (LinkError, CommandRefused) as exc:
            self._end(f"the link failed while streaming the path: {exc}", failure=True)
            return
        self.status_reads += 1
        self._follow(status.mode, status.waypoint_index, status.waypoint_count, status.waypoints_received)

    def _follow(self, mode: str, index: int, count: int | None = None, received: int | None = None) -> None:
        """The cart's progress, from telemetry (mode and index) or STATUS (all four). A telemetry
        frame may be older than the last XY_APPEND's reply (frames reach the listeners through a
        thread of their own, and one may wait behind a reply on the wire): an index behind the
        one known is stale, not a sign of another path, and a mode other than PATH is checked with
        STATUS. STATUS is answered in turn with the appends: a count or an index that went back
        there means another sender's path."""
        stale = count is None and index < self.index
        if mode != "PATH" and count is None:
            self._resync()  # a frame from before the path began says IDLE too: STATUS decides
        elif mode != "PATH":
            self._end(f"the firmware left PATH mode ({mode}) with {self.count - self.sent} points unsent")
        elif count is not None and (index < self.index or count != self.count):
            self._end("the path was replaced by another sender", failure=True)
        elif stale:
            return
        elif received is not None and received != self.sent:
            if self.sent <= received <= self.sent + POINTS_PER_FRAME:
                self.sent = received  # an append whose reply was lost had arrived
            else:
                self._end(f"the firmware holds {received} points, {self.sent} were sent", failure=True)
        else:
            self.index = index

    def _run(self, frames_seen: int) -> None:
        last_news = time.monotonic()
        last_status = 0.0
        while not self._cancelled.is_set() and not self.done.is_set():
            now = time.monotonic()
            frame = self.link.telemetry
            if self.link.telemetry_count != frames_seen and frame is not None:
                frames_seen = self.link.telemetry_count
                last_news = now
                self._follow(mode_name(frame.mode), int(frame.waypoint_index))
            elif now - last_news > TELEMETRY_STALE_S and now - last_status > STATUS_POLL_S:
                last_status = now
                self._resync()
            else:
                time.sleep(STREAM_POLL_S)
                continue
            room = self._room()
            if not self.done.is_set() and room >= min(self._batch, self.count - self.sent):
                self._fill(room)
                if self.sent >= self.count:
                    self.done.set()


def upload_path(link: Link, points: Sequence[Point], token: int | None = None) -> PathStream:
    """Sends a path of any length (PathStream): returns once its first frame and as many points
    as the window holds have arrived; the rest follows from the stream's thread. Its frames
    belong to the stop generation `token` (default: now): a STOP before the first raises
    MotionCancelled, and the path never starts; a STOP later ends the stream."""
    return PathStream(link, points, token).start()
