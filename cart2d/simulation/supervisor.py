"""The simulator's restart supervisor: when the simulator `cart2d sim` started exits on its own
(a crash, a kill -9), the mission ends with the reason (Gateway.abort), the user is told (/ws
message `simulator`, /api/status `simulator`, the bus's SimulatorExited and SimulatorRestarted)
and the simulator starts again, on the firmware it ran, then on the last one that answered.

It talks to the gateway through its public front only: a stop meanwhile waits for the program
that answers (Gateway.replacing_program), the restart watch is told the MCU restarts on purpose
(Restarts.resetting), an update under way ends first (the flasher)."""

from __future__ import annotations

import logging
import signal
import subprocess
import threading
import time
from dataclasses import asdict
from typing import Any

from cart2d.gateway import Gateway
from cart2d.gateway.bus import SimulatorExited, SimulatorRestarted, ViewerMessage
from cart2d.gateway.core import UPDATE_WAIT_S
from cart2d.gateway.messages import SimulatorMessage
from cart2d.gateway.state import SimulatorRun, SimulatorState
from cart2d.link import CommandRefused, LinkError
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator

log = logging.getLogger(__name__)

SIM_START_TRIES = 3
RETRY_PAUSE_S = 0.5  # between two attempts to start it


def exit_words(returncode: int) -> str:
    """How a process ended, in words: 'was killed by signal 9 (SIGKILL)', 'exited with status 1'."""
    if returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = "an unknown signal"
        return f"was killed by signal {-returncode} ({name})"
    return f"exited with status {returncode}"


class Supervisor:
    """Watches `sim` for `gateway` (see the module's docstring); its state is the status's
    "simulator" part."""

    def __init__(self, sim: Simulator, gateway: Gateway) -> None:
        self.sim = sim
        self.gateway = gateway
        self.state = SimulatorState()
        self._lock = threading.Lock()  # one exit handled at a time
        sim.on_exit = self.simulator_exited
        gateway.add_status_part("simulator", self.view)

    def view(self) -> dict[str, Any]:
        return asdict(self.state)

    def simulator_exited(self, process: subprocess.Popen[str], returncode: int) -> None:
        """The simulator's process ended without being asked to (its exit watcher's thread):
        the mission ends with the reason, the user is told, and the simulator starts again."""
        how = exit_words(returncode)
        when = time.strftime("%H:%M:%S")
        with self._lock, self.gateway.replacing_program():
            sentences = [f"The simulator {how} at {when}."]
            goal = self.gateway.abort(
                f"the simulator {how}: the simulated cart stopped with it",
                f"the simulator {how} before it squared up",
            )
            if goal is not None:
                sentences.append(f"The mission to ({goal[0]:.2f}, {goal[1]:.2f}) failed.")
            sentences.append("The gateway is starting it again.")
            self._tell(SimulatorState("restarting", self.state.restarts, " ".join(sentences)), log.warning)
            self.gateway.bus.publish(SimulatorExited(how))
            self._restart(process, how)

    def _restart(self, exited: subprocess.Popen[str], how: str) -> None:
        sim = self.sim
        self.gateway.flasher.wait(UPDATE_WAIT_S)  # an update under way ends first (its avrdude lost the port)
        error, answered = "", False
        with sim.lifecycle:
            if sim.process is exited or not sim.running():  # else restarted meanwhile
                error, answered = self._start_again(how)
        restarts = self.state.restarts + (0 if error else 1)
        if error:
            words = f"It could not be started again: {error}."
        elif answered:
            words = f"It runs again (restart {restarts}) and the firmware answers."
        else:
            words = f"It runs again (restart {restarts}), but the firmware does not answer yet."
        state: SimulatorRun = "failed" if error else "running"
        self._tell(
            SimulatorState(state, restarts, f"{self.state.message} {words}"),
            log.error if error else log.warning,
        )
        self.gateway.bus.publish(SimulatorRestarted(restarts, error, answered))

    def _start_again(self, how: str) -> tuple[str, bool]:
        """Starts the simulator on the firmware it ran (then on the last one that answered);
        returns why it could not ("" if it runs) and whether its firmware answered."""
        sim, gateway = self.sim, self.gateway
        error = ""
        with gateway.restarts.resetting(
            f"restarting the simulator, which {how}", certain=True, untrusts="a new simulator starts afresh"
        ):
            for attempt in range(SIM_START_TRIES):
                firmware_file = sim.options.firmware if attempt == 0 else gateway.flasher.good_firmware()
                try:
                    sim.restart(firmware_file)
                    error = ""
                    break
                except (SimulatorError, OSError) as exc:
                    error = str(exc)
                    time.sleep(RETRY_PAUSE_S)
            if error:
                return error, False
            try:
                gateway.link.connected.wait(10.0)
                gateway.wait_for_firmware(5.0, 0.1)
                return "", True
            except (LinkError, CommandRefused):
                return "", False

    def _tell(self, state: SimulatorState, say: Any) -> None:
        self.state = state
        say("%s", state.message)
        self.gateway.bus.publish(ViewerMessage(SimulatorMessage(**asdict(state))))
