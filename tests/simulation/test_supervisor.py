"""The simulator's restart supervisor (cart2d/simulation/supervisor.py) on a fake simulator and a
gateway on a fake firmware: what an exit ends, says and starts again, with no simulator and no
port. The end-to-end run with a real simulator killed is tests/test_server.py's."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import pytest

from cart2d.gateway import Gateway
from cart2d.gateway.bus import Event, SimulatorExited, SimulatorRestarted, ViewerMessage
from cart2d.simulation import supervisor as supervisor_module
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.supervisor import Supervisor, exit_words
from tests.support.fake_firmware import FakeFirmware


class FakeOptions:
    def __init__(self, firmware: Path) -> None:
        self.firmware = firmware


class FakeSim:
    """What the supervisor uses of a Simulator: its process, lifecycle lock and restart."""

    def __init__(self, cart: FakeFirmware, firmware: Path, failures: int = 0) -> None:
        self.cart = cart
        self.options = FakeOptions(firmware)
        self.process: object = object()
        self.lifecycle = threading.RLock()
        self.on_exit: Any = None
        self.failures = failures  # restarts that fail before one works
        self.started_on: list[Path | None] = []
        self.hold: threading.Event | None = None  # a restart waits for it when set

    def running(self) -> bool:
        return False  # it exited

    def restart(self, firmware: Path | None = None) -> None:
        self.started_on.append(firmware)
        if self.hold is not None:
            self.hold.wait(30.0)
        if self.failures > 0:
            self.failures -= 1
            raise SimulatorError("cart2d-sim exited (1) before it was ready")
        self.process = object()
        self.cart.restart()  # a new MCU: a new boot


@pytest.fixture(autouse=True)
def no_waits(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(supervisor_module, "RETRY_PAUSE_S", 0.0)


def watched(gateway: Gateway, sim: FakeSim) -> tuple[Supervisor, list[Event]]:
    events: list[Event] = []
    gateway.bus.subscribe(Event, events.append)
    return Supervisor(sim, gateway), events  # type: ignore[arg-type]  # the fake has what it uses


def told(events: list[Event]) -> list[dict[str, Any]]:
    return [e.wire for e in events if isinstance(e, ViewerMessage) and e.wire["type"] == "simulator"]


def test_an_exit_fails_the_mission_says_so_and_starts_the_simulator_again(
    gateway: Gateway, cart: FakeFirmware, tmp_path: Path
) -> None:
    sim = FakeSim(cart, tmp_path / "fw.elf")
    supervisor, events = watched(gateway, sim)
    gateway.check_firmware = lambda: None  # type: ignore[assignment,method-assign,return-value]  # it answers
    assert sim.on_exit == supervisor.simulator_exited
    assert gateway.status_view()["simulator"] == {"state": "running", "restarts": 0, "message": ""}
    gateway.go_to(1.6, 0.8)
    sim.on_exit(sim.process, -9)
    mission = gateway.mission_view()
    assert mission["state"] == "failed"
    assert (
        mission["reason"]
        == "the simulator was killed by signal 9 (SIGKILL): the simulated cart stopped with it"
    )
    assert sim.started_on == [tmp_path / "fw.elf"]  # on the firmware it ran
    restarting, running = told(events)
    assert (
        restarting["state"] == "restarting" and "The mission to (1.60, 0.80) failed." in restarting["message"]
    )
    assert running["state"] == "running" and running["restarts"] == 1
    assert running["message"].endswith("It runs again (restart 1) and the firmware answers.")
    assert gateway.status_view()["simulator"] == {k: v for k, v in running.items() if k != "type"}
    assert SimulatorExited("was killed by signal 9 (SIGKILL)") in events
    assert events[-1] == SimulatorRestarted(1, "", True)


def test_a_firmware_that_does_not_answer_after_the_restart_is_said_so(
    gateway: Gateway, cart: FakeFirmware, tmp_path: Path
) -> None:
    sim = FakeSim(cart, tmp_path / "fw.elf")
    _, events = watched(gateway, sim)  # the fake's VERSION is not this gateway's: it does not answer
    sim.on_exit(sim.process, 1)
    view = gateway.status_view()["simulator"]
    assert view["state"] == "running" and view["restarts"] == 1
    assert view["message"].endswith("It runs again (restart 1), but the firmware does not answer yet.")
    assert events[-1] == SimulatorRestarted(1, "", False)


def test_a_simulator_that_cannot_start_again_is_said_to_have_failed(
    gateway: Gateway, cart: FakeFirmware, tmp_path: Path
) -> None:
    sim = FakeSim(cart, tmp_path / "fw.elf", failures=supervisor_module.SIM_START_TRIES)
    _, events = watched(gateway, sim)
    sim.on_exit(sim.process, 1)
    view = gateway.status_view()["simulator"]
    assert view["state"] == "failed" and view["restarts"] == 0
    assert view["message"].endswith(
        "It could not be started again: cart2d-sim exited (1) before it was ready."
    )
    assert len(sim.started_on) == supervisor_module.SIM_START_TRIES
    assert events[-1] == SimulatorRestarted(0, "cart2d-sim exited (1) before it was ready", False)


def test_a_stop_while_the_simulator_restarts_waits_for_the_new_program_and_stops_it(
    gateway: Gateway, cart: FakeFirmware, tmp_path: Path
) -> None:
    sim = FakeSim(cart, tmp_path / "fw.elf")
    sim.hold = threading.Event()
    watched(gateway, sim)
    exited = threading.Thread(target=sim.on_exit, args=(sim.process, -9))
    exited.start()
    stopping = threading.Thread(target=gateway.stop)
    try:
        while not sim.started_on and exited.is_alive():  # the restart has begun (the fake holds it)
            exited.join(0.01)
        stopping.start()
        stopping.join(0.3)
        assert stopping.is_alive()  # waiting for the program, up to PROGRAM_WAIT_S
        assert "STOP" not in cart.requests
    finally:
        sim.hold.set()
        exited.join(10.0)
        stopping.join(10.0)
    assert not stopping.is_alive() and "STOP" in cart.requests


def test_exit_words() -> None:
    assert exit_words(-9) == "was killed by signal 9 (SIGKILL)"
    assert exit_words(1) == "exited with status 1"
    assert exit_words(-200) == "was killed by signal 200 (an unknown signal)"
