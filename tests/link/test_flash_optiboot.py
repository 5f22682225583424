"""avrdude through Optiboot in the simulated Nano (issue 15, "Flashing through the real
bootloader"): `make flash`'s very command writes another build of the firmware through the
simulator's pseudo-terminal, the flash stays across resets, and the gateway's firmware update
takes the same path. The simulator runs in real time while avrdude talks to it: avrdude's
timeouts and its wait after opening the port are wall-clock times, as with a real Nano."""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from cart2d.link import Link, flashing
from cart2d.link.built import default_bootloader, default_firmware
from cart2d.link.firmware import read_status, read_version
from cart2d.link.flashing import avrdude_command
from cart2d.link.transport import LinkTimeout
from cart2d.simulation.simulator import Simulator
from cart2d.spec import repo_file
from tests.support.server import OCTETS, Rig
from tests.support.sim import events, start_sim
from tests.support.waiting import wait_for

HEX = default_firmware().with_suffix(".hex")
PATCH = 7  # the other build answers VERSION with 0.1.7


def avrdude() -> str:
    path = shutil.which("avrdude")
    if path is None:
        pytest.fail("avrdude is needed (Debian package avrdude: make deps)")
    return path


@pytest.fixture(scope="module")
def other_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The firmware built again with another patch number: the same program, another VERSION."""
    out = tmp_path_factory.mktemp("other-build")
    make = ["make", "-s", "-C", str(repo_file()), f"{out}/cart2d-nano.hex", f"AVR_BUILD={out}"]
    subprocess.run([*make, f"AVR_EXTRA_FLAGS=-DCART2D_FIRMWARE_PATCH={PATCH}"], check=True, timeout=600)
    hex_file = out / "cart2d-nano.hex"
    assert hex_file.read_bytes() != HEX.read_bytes()
    return hex_file


@pytest.fixture
def nano(tmp_path: Path) -> Iterator[Simulator]:
    """A simulated Nano (with Optiboot, as every simulated Nano), in real time."""
    bootloader = default_bootloader()
    if not bootloader.exists():
        pytest.fail(f"{bootloader} is missing: run `make sim` (it builds Optiboot)")
    sim = start_sim(tmp_path, firmware=HEX, speed="1")
    assert sim.options.bootloader == bootloader
    yield sim
    sim.stop()


def firmware_version(sim: Simulator, wall_timeout_s: float = 10.0) -> str:
    """VERSION's firmware, from a port opened now: the open resets the Nano into Optiboot, whose
    wait the first requests cut short (a byte that is not STK500 makes it start the application
    through a 16 ms watchdog reset, after its LED flashes), so the first tries go unanswered."""
    deadline = time.monotonic() + wall_timeout_s
    with Link(sim.pty, timeout_s=0.2) as link:
        link.connected.wait(10)
        while True:
            try:
                return read_version(link).firmware
            except LinkTimeout:
                if time.monotonic() > deadline:
                    raise


def run_avrdude(sim: Simulator, *operations: str) -> tuple[subprocess.CompletedProcess[str], float, float]:
    """avrdude as `make flash` runs it, with these -U operations; and the simulated and wall
    seconds it took."""
    cmd = avrdude_command(avrdude(), sim.pty, 115200, Path("x"))[:-2]
    for operation in operations:
        cmd += ["-U", operation]
    t0, wall0 = float(sim.truth()["t"]), time.monotonic()
    done = flashing.run_avrdude(cmd, print)  # as the gateway does: once more if it never got in sync
    return done, float(sim.truth()["t"]) - t0, time.monotonic() - wall0


def test_avrdude_that_never_got_in_sync_is_run_once_more() -> None:
    # avrdude 7.1's arduino programmer gets in sync while it opens the port, and says "unable to
    # open programmer" when it never did; the retry looked for "initialization failed" only, so
    # an update whose avrdude lost the race with Optiboot's start failed ("not in sync:
    # resp=0xaa": the application's telemetry, once Optiboot had given up; 1 full run in 14 with
    # both cores busy). Here the real avrdude, on a port where an application sends telemetry
    # frames' first bytes and no bootloader answers.
    master, slave = os.openpty()
    done_talking = threading.Event()

    def telemetry() -> None:
        while not done_talking.wait(0.005):
            with contextlib.suppress(OSError):
                os.write(master, b"\xaa\xbb")

    talker = threading.Thread(target=telemetry, daemon=True)
    talker.start()
    try:
        notes: list[str] = []
        cmd = [avrdude(), "-p", "m328p", "-c", "arduino", "-P", os.ttyname(slave), "-b", "115200"]
        done = flashing.run_avrdude([*cmd, "-U", f"flash:v:{HEX}:i"], notes.append)
    finally:
        done_talking.set()
        talker.join()
        os.close(master)
        os.close(slave)
    assert done.returncode != 0 and "not in sync" in done.stderr, done.stderr
    assert notes == ["avrdude could not get in sync with the bootloader: once more"]


def test_avrdude_flashes_the_simulated_nano_through_optiboot(nano: Simulator, other_build: Path) -> None:
    assert firmware_version(nano) == "0.1.0"
    done, sim_s, wall_s = run_avrdude(nano, f"flash:w:{other_build}:i")
    assert done.returncode == 0, done.stderr
    records = [line for line in other_build.read_text().split() if line[7:9] == "00"]
    size = sum(int(line[1:3], 16) for line in records)
    assert f"{size} bytes of flash verified" in done.stderr, done.stderr
    # avrdude's DTR/RTS ioctls fail on a pseudo-terminal; it warns and goes on, and the
    # simulator's reset on opening the port stands in for the Nano's auto-reset capacitor.
    print(f"\n  avrdude writes and verifies {size} B through Optiboot at 115200: ", end="")
    print(f"{sim_s:.2f} s simulated, {wall_s:.2f} s wall (from opening the port)")
    assert firmware_version(nano) == f"0.1.{PATCH}"
    # The flash is the chip's, not the file's: it stays through a power cycle and an external reset.
    nano.reset("power", off_s=0.5)
    assert firmware_version(nano) == f"0.1.{PATCH}"
    done, _, _ = run_avrdude(nano, f"flash:v:{other_build}:i")
    assert done.returncode == 0 and f"{size} bytes of flash verified" in done.stderr, done.stderr
    done, _, _ = run_avrdude(nano, f"flash:v:{HEX}:i")
    assert done.returncode != 0 and "verification mismatch" in done.stderr, done.stderr


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def test_avrdude_over_a_network_link_resets_the_nano_by_ser2net_opening_its_port(
    nano: Simulator, other_build: Path, tmp_path: Path
) -> None:
    """avrdude -P net:HOST:PORT is raw TCP: no DTR travels (its ioctls fail as on a pty). What
    resets the Nano is ser2net opening the serial device when the connection comes (Linux raises
    DTR on open; the simulator resets on open), and closing it afterwards, so the next connection
    resets it again. docs/firmware.md, "Flashing over a network link"."""
    ser2net = shutil.which("ser2net")
    if ser2net is None:
        pytest.fail("ser2net is needed (Debian package ser2net: make deps)")
    port = free_port()
    config = tmp_path / "ser2net.yaml"
    config.write_text(
        "connection: &nano\n"
        f"  accepter: tcp(nodelay),127.0.0.1,{port}\n"
        f"  connector: serialdev,{nano.pty},115200n81,local\n"
        "  options:\n"
        "    chardelay: false\n"
    )
    bridge = subprocess.Popen([ser2net, "-n", "-c", str(config), "-P", str(tmp_path / "pid")])
    try:
        opens = len(events(nano, "host_open"))
        cmd = avrdude_command(avrdude(), f"net:127.0.0.1:{port}", 115200, other_build)
        for _ in range(50):  # until ser2net listens
            with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), timeout=0.1):
                break
            time.sleep(0.1)
        wait_for(lambda: len(events(nano, "host_open")) > opens, 10)  # the probe's connection opened it
        wait_for(lambda: len(events(nano, "host_close")) >= 1, 10)
        opens = len(events(nano, "host_open"))
        done = flashing.run_avrdude(cmd, print)
        assert done.returncode == 0 and "bytes of flash verified" in done.stderr, done.stderr
        assert [e["reset"] for e in events(nano, "host_open")[opens:]] == [True]  # one open, one reset
    finally:
        bridge.terminate()
        bridge.wait(10)
    assert firmware_version(nano) == f"0.1.{PATCH}"


def reset_cause(sim: Simulator, after: Any = None) -> list[str]:
    """STATUS's reset_cause from a port opened now (after calling `after(link)` once the
    firmware answers), read without reopening the port."""
    deadline = time.monotonic() + 10.0
    with Link(sim.pty, timeout_s=0.2) as link:
        while True:
            try:
                status = read_status(link)
                break
            except LinkTimeout:
                if time.monotonic() > deadline:
                    raise
        if after is None:
            return list(status.reset_cause)
        after(link)
        while True:
            try:
                later = read_status(link)
                if later.restarted_since(status):
                    return list(later.reset_cause)
            except LinkTimeout:
                pass
            if time.monotonic() > deadline:
                raise AssertionError("the firmware did not restart")


def test_behind_optiboot_the_firmware_tells_the_reset_causes_it_can(nano: Simulator) -> None:
    """Optiboot 4.4 clears MCUSR and passes nothing on (r2 holds what it held): the firmware
    tells a power-on from a reset that kept the RAM, and a REBOOT by its marker."""
    nano.reset("power", off_s=0.5)
    nano.control("link", auto_reset=False)  # this open must not reset it again
    assert reset_cause(nano) == ["POWER_ON"]
    nano.control("link", auto_reset=True)
    # Opening the port resets the MCU (DTR): Optiboot waits, its watchdog starts the firmware.
    assert sorted(reset_cause(nano)) == ["EXTERNAL", "WATCHDOG"]
    nano.control("link", auto_reset=False)
    assert sorted(reset_cause(nano, after=lambda link: link.call("REBOOT"))) == ["REBOOT", "WATCHDOG"]


def update(rig: Rig, data: bytes) -> dict[str, Any]:
    response = rig.client.post("/api/firmware/update", content=data, headers=OCTETS)
    assert response.status_code == 202, response.text
    wait_for(lambda: rig.client.get("/api/firmware/update").json()["state"] != "running", 120)
    job: dict[str, Any] = rig.client.get("/api/firmware/update").json()
    return job


def test_the_gateways_update_flashes_the_simulator_through_avrdude(rig: Rig, other_build: Path) -> None:
    assert rig.sim.process is not None
    pid = rig.sim.process.pid
    job = update(rig, other_build.read_bytes())
    assert job["state"] == "done", job["log"]
    assert any("avrdude" in line and "-c arduino" in line for line in job["log"]), job["log"]
    assert any("bytes of flash verified" in line for line in job["log"]), job["log"]
    assert rig.sim.process.pid == pid  # flashed in place, not restarted
    status = rig.client.get("/api/status").json()
    assert status["link"]["state"] == "connected" and status["firmware"]["firmware"] == f"0.1.{PATCH}"


def test_a_firmware_that_does_not_answer_is_flashed_back_through_avrdude(
    rig: Rig, request: pytest.FixtureRequest
) -> None:
    """Issue 11, finding 3, on the avrdude path: the last firmware that answered is written back
    through Optiboot, which a reset reaches whatever the application does. The rig's simulator
    started on the ELF, as `cart2d sim` does: the rollback writes it back with avrdude's `:e`."""
    job = update(rig, request.getfixturevalue("half_duty_hex"))  # both motors at 50 %, no protocol
    assert job["state"] == "failed" and "the previous firmware runs again" in job["log"][-1], job["log"]
    assert sum("bytes of flash verified" in line for line in job["log"]) == 2, job["log"]  # there and back
    # what a restart would load: the file that answered (the simulator's ELF, kept by content)
    assert rig.sim.options.firmware.read_bytes() == default_firmware().read_bytes()
    status = rig.client.get("/api/status").json()
    assert status["link"]["state"] == "connected" and status["firmware"]["firmware"] == "0.1.0"
    assert rig.client.post("/api/command", json={"name": "POSE", "args": []}).json()["status"] == "CONTROL_OK"
