"""Starting cart2d-sim and talking to its side channel (ground truth and control).

The simulator prints one JSON line when ready: the pseudo-terminal to open as the robot's
serial port and the TCP address of the side channel (JSON lines, see sim/README.md). A
Simulator watches its process: an exit it did not ask for (a crash, a kill -9) is reported to
`on_exit`, so that its owner can tell the user and start it again.

The simulated world it is given is cart2d/maps/world.py's; the side channel side_channel.py's.
"""

from __future__ import annotations

import contextlib
import json
import subprocess
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cart2d.link.built import default_binary, default_bootloader, default_firmware
from cart2d.maps.world import Box, World
from cart2d.simulation.controls import CameraControls
from cart2d.simulation.side_channel import SideChannel, SimulatorError


@dataclass
class SimOptions:
    firmware: Path = field(default_factory=default_firmware)
    binary: Path = field(default_factory=default_binary)
    speed: str = "1"  # a factor, or "max"
    seed: int = 1
    eeprom: Path | None = None
    start: tuple[float, float, float] | None = None
    truth_hz: float = 50.0
    paused: bool = False  # start paused: nothing runs until resume() or run_for()
    pty_link: Path | None = None  # a stable name for the serial port, across restarts
    grid: tuple[int, float] | None = None  # square arena: nodes per side, step (m)
    # The physical world, set before the firmware runs (it replaces the square arena of `grid`);
    # `start` is then checked against it.
    world: World | None = None
    # How the world looks to the camera (sim/README.md, "The look"; a world file's "look"), set
    # before the firmware runs and again at every restart. None: today's look.
    look: dict[str, Any] | None = None
    quiet: bool = False  # only warnings and errors from the simulator on stderr
    # The host's end of the serial line (sim/README.md, "UART model"): the adapter's baud rate,
    # the USB delay each way in simulated ms (to the MCU, to the host), the FTDI latency timer
    # (0: off; an FT232R's default is 16 ms), and whether opening the port resets the MCU (DTR).
    host_baud: float = 115200.0
    usb_latency_ms: tuple[float, float] = (0.0, 0.0)
    ftdi_latency_timer_ms: float = 0.0
    auto_reset: bool = True
    # Faults (sim/README.md, "Fault keys"; cart2d/faults.py checks them), set before the firmware
    # runs and again at every restart.
    faults: dict[str, float] = field(default_factory=dict)
    # Optiboot in the boot section (--bootloader), as on every Nano: resets start it, and avrdude
    # (the gateway's firmware update) flashes through the pty. None: the bare chip, the firmware
    # at the reset vector (tests of the chip itself; no firmware update is possible then).
    bootloader: Path | None = field(default_factory=default_bootloader)


ExitListener = Callable[["subprocess.Popen[str]", int], None]


class Simulator(CameraControls):
    """A running cart2d-sim process (camera and target: cart2d/simulation/controls.py)."""

    def __init__(self, options: SimOptions | None = None) -> None:
        self.options = options or SimOptions()
        self.process: subprocess.Popen[str] | None = None
        self.pty = ""
        self.control_address = ""
        self.side: SideChannel | None = None
        # Held while the process is stopped or started: one (re)start at a time.
        self.lifecycle = threading.RLock()
        self._truth_listeners: list[Callable[[dict[str, Any]], None]] = []
        self._stopped_on_purpose: set[int] = set()  # pids of processes we stopped or killed
        # Called (from a thread of its own) with the process and its exit status when the
        # process exits without being asked to: a crash, or killed from outside.
        self.on_exit: ExitListener | None = None

    def start(self) -> Simulator:
        o = self.options
        needed = [(o.binary, "simulator (make sim)"), (o.firmware, "firmware (make firmware)")]
        if o.bootloader is not None:
            needed.append((o.bootloader, "bootloader (make sim builds Optiboot)"))
        for path, what in needed:
            if not Path(path).exists():
                raise SimulatorError(f"the {what} is not built: {path}")
        cmd = [str(o.binary), "--firmware", str(o.firmware), "--speed", o.speed, "--seed", str(o.seed)]
        cmd.append("--exit-with-parent")
        cmd += ["--truth-hz", str(o.truth_hz)]
        if o.eeprom is not None:
            cmd += ["--eeprom", str(o.eeprom)]
        if o.paused or o.world is not None or o.faults:
            cmd.append("--paused")  # resumed once the world and the faults are set
        if o.quiet:
            cmd.append("--quiet")
        if o.grid is not None:
            cmd += ["--grid", f"{o.grid[0]},{o.grid[1]}"]
        if o.pty_link is not None:
            cmd += ["--pty-link", str(o.pty_link)]
        if o.start is not None and o.world is None:
            cmd += ["--start", ",".join(str(v) for v in o.start)]
        if o.host_baud != 115200.0:
            cmd += ["--host-baud", str(o.host_baud)]
        if any(o.usb_latency_ms):
            cmd += ["--usb-latency", ",".join(str(v) for v in o.usb_latency_ms)]
        if o.ftdi_latency_timer_ms > 0:
            cmd += ["--ftdi-latency-timer", str(o.ftdi_latency_timer_ms)]
        if not o.auto_reset:
            cmd.append("--no-auto-reset")
        if o.bootloader is not None:
            cmd += ["--bootloader", str(o.bootloader)]
        # Its own session: a Ctrl-C in the terminal reaches us, and we stop it in order. Its stdin
        # is a pipe we hold open: when this process ends, however, the simulator sees the end
        # of file and stops (--exit-with-parent).
        with self.lifecycle:
            process = subprocess.Popen(
                cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, start_new_session=True
            )
            assert process.stdout is not None
            line = process.stdout.readline()
            if not line:
                raise SimulatorError(f"cart2d-sim exited ({process.wait()}) before it was ready")
            self.process = process
            ready = json.loads(line)
            self.pty = ready["pty"]
            self.control_address = ready["control"]
            self.side = SideChannel(self.control_address)
            for listener in self._truth_listeners:
                self.side.subscribe(listener)
            threading.Thread(target=self._watch_exit, args=(process,), name="sim exit", daemon=True).start()
            if o.world is not None or o.faults or o.look is not None:
                try:
                    if o.faults:
                        self.control("faults", clear=True, **o.faults)
                    if o.look is not None:
                        self.control("look", look=o.look)
                    if o.world is not None:
                        self.set_world(o.world)
                        if o.start is not None:
                            x, y, theta = o.start
                            self.control("place", x=x, y=y, theta=theta)
                except SimulatorError:
                    self.stop()
                    raise
                if not o.paused:
                    self.control("resume")
        return self

    def running(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def boot_s(self) -> float:
        """Simulated seconds from an external reset (the button, the port opening) until the
        firmware runs when nothing is sent: the reset time-out (65 ms) and the firmware's start;
        behind Optiboot also its LED flashes (375 ms) and its 1 s wait for a programmer, which
        ends in a watchdog reset (65 ms). docs/firmware.md, "Start-up time after a reset"."""
        return 1.6 if self.options.bootloader is not None else 0.1

    def subscribe_truth(self, listener: Callable[[dict[str, Any]], None]) -> None:
        """Calls listener(message) for every truth message, from the side channel's reader
        thread, across restarts of the simulator."""
        self._truth_listeners.append(listener)
        if self.side is not None:
            self.side.subscribe(listener)

    def _watch_exit(self, process: subprocess.Popen[str]) -> None:
        code = process.wait()
        if process.pid in self._stopped_on_purpose:
            return
        listener = self.on_exit
        if listener is not None:
            listener(process, code)

    def control(self, kind: str, **members: Any) -> dict[str, Any]:
        if self.side is None:
            raise SimulatorError("the simulator is not running")
        return self.side.request({"type": kind, **members})

    def faults(self) -> dict[str, float]:
        """Every fault key with its value now (sim/README.md, "Fault keys")."""
        current: dict[str, float] = self.control("faults")["faults"]
        return current

    def set_faults(self, faults: dict[str, float]) -> dict[str, float]:
        """Replaces the faults (keys not given: off), now and at every restart; returns them all.
        Check them first (cart2d/faults.py): the simulator refuses the whole set at a bad one."""
        with self.lifecycle:  # a restart meanwhile starts with the new set
            current: dict[str, float] = self.control("faults", clear=True, **faults)["faults"]
            self.options.faults = dict(faults)
        return current

    def set_world(self, world: World, at_s: float | None = None) -> dict[str, Any]:
        """Replaces the physical world, now or at simulated time at_s; returns the ack."""
        return self.control("world", **world.message(), **_at(at_s))

    def set_look(self, look: dict[str, Any] | None) -> None:
        """How the world looks to the camera (None: today's look), now and at every restart."""
        with self.lifecycle:
            self.control("look", look=look)
            self.options.look = look

    def add_boxes(self, boxes: Sequence[Box], at_s: float | None = None) -> dict[str, Any]:
        return self.control("boxes", add=[b.message() for b in boxes], **_at(at_s))

    def remove_boxes(self, ids: Sequence[str], at_s: float | None = None) -> dict[str, Any]:
        return self.control("boxes", remove=list(ids), **_at(at_s))

    def change_obstacles(
        self,
        add: Sequence[tuple[float, float]] = (),
        remove: Sequence[tuple[float, float]] = (),
        step: float | None = None,
        physical: bool = False,
        at_s: float | None = None,
    ) -> dict[str, Any]:
        """Adds and removes virtual obstacles (cell centres, m; cells of side `step`), now or at
        simulated time at_s. Physical: each added one is also a box of its cell (a mission's event
        obstacle: the cart cannot pass it, and overlapping it still counts as a collision)."""
        members: dict[str, Any] = {"add": [list(p) for p in add], "remove": [list(p) for p in remove]}
        if step is not None:
            members["step"] = step
        return self.control("obstacles", physical=physical, **members, **_at(at_s))

    def world_state(self) -> dict[str, Any]:
        """The world as the simulator holds it: walls, boxes, obstacles, scheduled changes."""
        state: dict[str, Any] = self.control("world_get")["world"]
        return state

    def run_for(self, seconds: float, wall_timeout_s: float = 60.0) -> dict[str, Any]:
        """Runs exactly `seconds` of simulated time, then pauses; returns the truth there."""
        if self.side is None:
            raise SimulatorError("the simulator is not running")
        seen = len(self.side.events)
        self.control("run", seconds=seconds)

        def paused(_: dict[str, Any]) -> bool:
            return any(e.get("event") == "paused" for e in self.side.events[seen:]) if self.side else False

        self.side.wait_truth(paused, wall_timeout_s)
        return self.truth()

    def reset(self, cause: str = "external", wait: bool = True, **members: Any) -> None:
        """Resets the simulated MCU: "external" (the button, DTR), "power" (off_s: seconds without
        power) or "brownout" (dip_s). As on the board the chip then runs nothing for its reset
        time-out and the UART loses what arrives meanwhile; with wait, this returns once the MCU
        runs again (nothing waits while the simulator is paused)."""
        self.control("reset", cause=cause, **members)
        if wait and not self.control("stats")["stats"]["paused"]:
            self.wait_running()

    def wait_running(self, wall_timeout_s: float = 30.0) -> None:
        """Waits until the MCU is out of reset (power off, brown-out dip or the time-out)."""
        deadline = time.monotonic() + wall_timeout_s
        while self.control("stats")["stats"]["mcu"] == "reset":
            if time.monotonic() > deadline:
                raise SimulatorError("the MCU stays in reset")
            time.sleep(0.002)

    def truth(self) -> dict[str, Any]:
        truth: dict[str, Any] = self.control("truth")["truth"]
        return truth

    def restart(self, firmware: Path | None = None) -> None:
        """Stops the simulator and starts it again (the EEPROM file is kept), with a new
        firmware file if given; truth listeners carry over. With a pty_link the serial port
        keeps its name, so an open Link reconnects by itself."""
        with self.lifecycle:
            listeners = list(self.side.listeners) if self.side is not None else []
            extra = [listener for listener in listeners if listener not in self._truth_listeners]
            self.stop()
            if firmware is not None:
                self.options.firmware = firmware
            self.start()
            assert self.side is not None
            for listener in extra:
                self.side.subscribe(listener)

    def kill(self) -> None:
        """Ends the process abruptly (SIGKILL), as a crash would, but on purpose: on_exit is
        not called (a kill from outside, `kill -9 PID`, calls it)."""
        if self.process is not None:
            self._stopped_on_purpose.add(self.process.pid)
            self.process.kill()
            self.process.wait()
            self.process = None
        if self.side is not None:
            self.side.close()
            self.side = None

    def stop(self) -> None:
        if self.process is not None:
            self._stopped_on_purpose.add(self.process.pid)
        if self.side is not None:
            with contextlib.suppress(SimulatorError):  # it may be gone already
                self.control("quit")
            self.side.close()
            self.side = None
        if self.process is not None:
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
            self.process = None

    def __enter__(self) -> Simulator:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _at(at_s: float | None) -> dict[str, Any]:
    return {} if at_s is None else {"at": at_s}
