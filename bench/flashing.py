"""## Flashing through Optiboot: avrdude and the simulated Nano

`make flash`'s command (`avrdude -c arduino -p m328p -b 115200 -D -U flash:w:FILE:i`, which
writes and then reads back to verify) against the simulator running Optiboot in its boot section
(sim/README.md, "Bootloader and avrdude"), in real time: avrdude's waits are wall-clock times.
Each run opens the port (the DTR reset into Optiboot) and writes the built firmware. Times are
from avrdude's start to its end, in simulated seconds (from the simulator's clock) and wall
seconds; avrdude's own "Writing" and "Reading" bars give the two phases. Through ser2net (raw
TCP on localhost, `avrdude -P net:127.0.0.1:PORT`), with ser2net's defaults and with
`tcp(nodelay)` and `chardelay: false` (docs/firmware.md, "Flashing over a network link").

`python -m bench.flashing [--quick]` (quick: the direct line only, once).
"""

from __future__ import annotations

import re
import shutil
import socket
import subprocess
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from bench.common import Section, section_main, table
from cart2d.link.built import default_bootloader, default_firmware
from cart2d.link.flashing import avrdude_command, run_avrdude
from cart2d.simulation.simulator import SimOptions, Simulator

HEX = default_firmware().with_suffix(".hex")


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def ser2net_config(pty: str, port: int, tuned: bool) -> str:
    accepter = f"tcp(nodelay),127.0.0.1,{port}" if tuned else f"tcp,127.0.0.1,{port}"
    text = f"connection: &nano\n  accepter: {accepter}\n  connector: serialdev,{pty},115200n81,local\n"
    return text + ("  options:\n    chardelay: false\n" if tuned else "")


def phase_s(stderr: str, bar: str) -> float:
    found = re.search(bar + r" \| #+ \| 100% ([0-9.]+)s", stderr)
    return float(found.group(1)) if found else float("nan")


def flash_once(sim: Simulator, port: str) -> dict[str, float]:
    avrdude = shutil.which("avrdude")
    if avrdude is None:
        raise SystemExit("avrdude is not installed (make deps)")
    t0, wall0 = float(sim.truth()["t"]), time.monotonic()
    done = run_avrdude(avrdude_command(avrdude, port, 115200, HEX), print)
    if done.returncode != 0 or "bytes of flash verified" not in done.stderr:
        raise RuntimeError(f"avrdude failed ({done.returncode}): {done.stderr[-500:]}")
    return {
        "sim_s": float(sim.truth()["t"]) - t0,
        "wall_s": time.monotonic() - wall0,
        "writing_s": phase_s(done.stderr, "Writing"),
        "reading_s": phase_s(done.stderr, "Reading"),
    }


def through_ser2net(sim: Simulator, tmp: Path, tuned: bool) -> dict[str, float]:
    ser2net = shutil.which("ser2net")
    if ser2net is None:
        raise SystemExit("ser2net is not installed (make deps)")
    port = free_port()
    config = tmp / f"ser2net-{tuned}.yaml"
    config.write_text(ser2net_config(sim.pty, port, tuned))
    bridge = subprocess.Popen([ser2net, "-n", "-c", str(config), "-P", str(tmp / f"ser2net-{tuned}.pid")])
    try:
        time.sleep(1.0)  # until it listens
        return flash_once(sim, f"net:127.0.0.1:{port}")
    finally:
        bridge.terminate()
        bridge.wait(10)


def run(out: Path, quick: bool) -> Section:
    del out  # no plots
    size = sum(int(line[1:3], 16) for line in HEX.read_text().split() if line[7:9] == "00")
    rows: list[list[object]] = []
    data: dict[str, object] = {"bytes": size}
    with tempfile.TemporaryDirectory(prefix="cart2d-bench-flash-") as tmp:
        options = SimOptions(
            firmware=HEX, bootloader=default_bootloader(), speed="1", eeprom=Path(tmp) / "e.bin", quiet=True
        )
        with Simulator(options) as sim:
            runs: dict[str, Callable[[], dict[str, float]]] = {
                "direct (the pty)": lambda: flash_once(sim, sim.pty)
            }
            if not quick:
                runs["ser2net, defaults"] = lambda: through_ser2net(sim, Path(tmp), tuned=False)
                runs["ser2net, nodelay, no chardelay"] = lambda: through_ser2net(sim, Path(tmp), tuned=True)
            for name, measure in runs.items():
                m = measure()
                data[name] = m
                rows.append(
                    [
                        name,
                        f"{m['sim_s']:.2f}",
                        f"{m['wall_s']:.2f}",
                        f"{m['writing_s']:.2f}",
                        f"{m['reading_s']:.2f}",
                    ]
                )
    markdown = (
        "## Flashing through Optiboot\n\n"
        f"avrdude writes and verifies the firmware ({size} bytes, {(size + 127) // 128} pages) through "
        "the simulated Nano's Optiboot at 115 200 baud, from opening the port:\n\n"
        + table(["link", "simulated s", "wall s", "writing s (wall)", "reading s (wall)"], rows)
        + "\n"
    )
    return Section("flashing", markdown, data)


if __name__ == "__main__":
    raise SystemExit(section_main(run))
