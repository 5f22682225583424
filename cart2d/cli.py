"""The `cart2d` command line: `sim` (simulator + gateway), `serve` (a real robot on a serial
port), `mission` (a headless mission run with a report), `calibrate` (odometry, UMBmark)."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from types import FrameType

import uvicorn

from cart2d.calibrate import add_arguments as add_calibrate_arguments
from cart2d.calibrate import main_calibrate
from cart2d.gateway import Gateway
from cart2d.link import Link, LinkError
from cart2d.server import create_app, is_loopback
from cart2d.server.live import listening_socket
from cart2d.simulator import SimOptions, Simulator, SimulatorError
from cart2d.store import GatewaySettings, NetworkSettings, Store

log = logging.getLogger("cart2d")


def _network_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", help="bind address (default: the saved one, 127.0.0.1 at first)")
    parser.add_argument("--port", type=int, help="HTTP port (default: the saved one, 8080 at first)")


def _settings(store: Store, args: argparse.Namespace) -> GatewaySettings:
    settings = store.load()
    network = settings.network
    if args.host or args.port:
        network = NetworkSettings(host=args.host or network.host, port=args.port or network.port)
        settings = settings.model_copy(update={"network": network})
    if not is_loopback(network.host):
        settings = store.ensure_token(settings)
    return settings


def _connect(gateway: Gateway, wait_s: float) -> None:
    """Checks the firmware once it answers (a Nano resets when its port opens: give it time)."""
    try:
        version = gateway.wait_for_firmware(wait_s, 0.5)
    except LinkError as exc:
        log.warning("%s; the gateway starts anyway and keeps trying", exc)
        return
    log.info("firmware %s on %s", version.firmware, gateway.link.port)


def _serve(gateway: Gateway, settings: GatewaySettings) -> None:
    host, port = settings.network.host, settings.network.port
    app = create_app(gateway, host, settings.token)
    shown = "127.0.0.1" if host in ("0.0.0.0", "::") else host
    print(f"cart2d panel: http://{shown}:{port}/   (Ctrl-C stops)", flush=True)
    if settings.token and not is_loopback(host):
        print(f"access token (needed off this machine): {settings.token}", flush=True)
    sock = listening_socket(host, port)  # send buffers capped for viewers that stop reading
    uvicorn.Server(uvicorn.Config(app, log_level="warning")).run(sockets=[sock])


def cmd_sim(args: argparse.Namespace) -> int:
    store = Store()
    settings = _settings(store, args)
    store.directory.mkdir(parents=True, exist_ok=True)
    options = SimOptions(
        speed=args.speed,
        seed=args.seed,
        eeprom=store.directory / "sim-eeprom.bin",
        pty_link=store.directory / "sim-tty",
    )
    try:
        sim = Simulator(options).start()
    except SimulatorError as exc:
        print(f"cart2d: {exc}", file=sys.stderr)
        return 2
    link = Link(sim.pty).open()
    gateway = Gateway(link, store, settings, sim)
    try:
        _connect(gateway, 5.0)
        gateway.start()
        print(
            f"simulator running ({args.speed}x real time), robot serial port {sim.pty}, "
            f"side channel {sim.control_address}",
            flush=True,
        )
        _serve(gateway, settings)
    finally:
        gateway.close()
        link.close()
        sim.stop()
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    store = Store()
    settings = _settings(store, args)
    link = Link(args.serial, args.baud)
    try:
        link.open(wait_s=3.0)
    except LinkError as exc:
        log.warning("%s; retrying in the background", exc)
    gateway = Gateway(link, store, settings)
    try:
        _connect(gateway, 5.0)
        gateway.start()
        _serve(gateway, settings)
    finally:
        gateway.close()
        link.close()
    return 0


def cmd_mission(args: argparse.Namespace) -> int:
    from cart2d.mission import main_mission  # tqdm and friends only for this command

    return main_mission(args.mission, args.report, args.speed, args.seed)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="cart2d", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true")
    sub = parser.add_subparsers(dest="command", required=True)

    sim = sub.add_parser("sim", help="the simulator running the built firmware, with the gateway and panel")
    _network_args(sim)
    sim.add_argument("--speed", default="1", help="simulated seconds per second, or 'max' (default 1)")
    sim.add_argument("--seed", type=int, default=1, help="seed of the simulator's random faults")
    sim.set_defaults(run=cmd_sim)

    serve = sub.add_parser("serve", help="the gateway and panel for a real cart on a serial port")
    serve.add_argument("--serial", required=True, help="the Nano's serial port, e.g. /dev/ttyUSB0")
    serve.add_argument("--baud", type=int, default=115200)
    _network_args(serve)
    serve.set_defaults(run=cmd_serve)

    mission = sub.add_parser("mission", help="run a mission in the simulator and write a report")
    mission.add_argument("mission", type=Path, help="MISSION.json: grid, obstacles, start, goals, ...")
    mission.add_argument("--report", type=Path, required=True, help="where to write REPORT.json")
    mission.add_argument("--speed", default="max", help="simulated seconds per second, or 'max' (default)")
    mission.add_argument("--seed", type=int, default=1)
    mission.set_defaults(run=cmd_mission)

    calibrate = sub.add_parser("calibrate", help="odometry calibration (UMBmark): wheel radii and track")
    add_calibrate_arguments(calibrate)
    calibrate.set_defaults(run=main_calibrate)
    return parser


def _stop_like_ctrl_c(signum: int, frame: FrameType | None) -> None:
    # uvicorn re-raises a SIGTERM it caught once it has shut down; with the default action the
    # process would die there, before the finally blocks that stop the simulator and the link.
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _stop_like_ctrl_c)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING, format="%(name)s: %(message)s"
    )
    try:
        code: int = args.run(args)
    except KeyboardInterrupt:
        code = 0
    return code


if __name__ == "__main__":
    sys.exit(main())
