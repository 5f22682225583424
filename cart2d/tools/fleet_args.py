"""`--mqtt URL --fleet-id NAME` on `cart2d sim` and `cart2d serve`: the gateway joins a fleet as
a VDA 5050 vehicle on that broker (cart2d/fleet/)."""

from __future__ import annotations

import argparse
import contextlib
import logging
import re
from collections.abc import Iterator
from pathlib import Path

from cart2d.fleet.gateway_vehicle import join_fleet
from cart2d.fleet.mqtt import PASSWORD_VARIABLE, Broker
from cart2d.gateway import Gateway

log = logging.getLogger("cart2d")
FLEET_ID = re.compile(r"[A-Za-z0-9_.-]{1,64}")  # a topic level: no '/', '+' or '#'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--mqtt",
        metavar="URL",
        help="join a fleet: a VDA 5050 2.1 vehicle on this MQTT broker, mqtt://[USER[:PASSWORD]@]HOST[:PORT] "
        f"or mqtts://... for TLS (a password not in the URL is taken from ${PASSWORD_VARIABLE})",
    )
    parser.add_argument(
        "--fleet-id", metavar="NAME", help="this cart's name in the fleet (its VDA 5050 serialNumber)"
    )
    parser.add_argument(
        "--mqtt-ca", type=Path, metavar="FILE", help="mqtts://: the CA certificate the broker's is signed by"
    )


def problem(args: argparse.Namespace) -> str:
    """What is wrong with the fleet's options, in a sentence ("" if nothing)."""
    if args.mqtt is None:
        return "--fleet-id and --mqtt-ca need --mqtt" if args.fleet_id or args.mqtt_ca else ""
    try:
        Broker.of(args.mqtt)
    except ValueError as exc:
        return f"--mqtt: {exc}"
    if not args.fleet_id or not FLEET_ID.fullmatch(args.fleet_id):
        return "--mqtt needs --fleet-id NAME (1 to 64 letters, digits, '_', '.', '-')"
    if args.mqtt_ca is not None and not args.mqtt_ca.is_file():
        return f"--mqtt-ca: no file {args.mqtt_ca}"
    return ""


@contextlib.contextmanager
def fleet_vehicle(gateway: Gateway, args: argparse.Namespace) -> Iterator[None]:
    """The gateway as a vehicle of --mqtt's fleet while the block runs (nothing without --mqtt)."""
    if args.mqtt is None:
        yield
        return
    broker = Broker.of(args.mqtt, str(args.mqtt_ca) if args.mqtt_ca else None)
    vehicle = join_fleet(gateway, broker, args.fleet_id)
    print(f"fleet: VDA 5050 vehicle {args.fleet_id} on {broker}", flush=True)
    try:
        yield
    finally:
        vehicle.close()
