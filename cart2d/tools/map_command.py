"""`cart2d map save NAME`: asks the running gateway (cart2d sim / serve) to write what its
camera has seen as a ROS map_server map (POST /api/map/save); and `--map FILE.yaml` on sim and
serve, which loads a map_server map as the floor plan."""

from __future__ import annotations

import argparse
import json
import sys
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

from cart2d.gateway.map_saving import checked_name
from cart2d.maps.occupancy import MapError, OccupancyMap
from cart2d.maps.ros import load_ros_map


def add_save_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", help="the map's name: NAME.yaml and NAME.pgm in the gateway's maps folder")
    parser.add_argument(
        "--url", default="http://127.0.0.1:8080", help="the gateway's address (default http://127.0.0.1:8080)"
    )
    parser.add_argument(
        "--token", default="", help="the access token, if the gateway listens beyond loopback"
    )


def cmd_map_save(args: argparse.Namespace) -> int:
    try:
        checked_name(args.name)
    except ValueError as exc:
        print(f"cart2d map save: {exc}", file=sys.stderr)
        return 2
    request = urllib.request.Request(
        args.url.rstrip("/") + "/api/map/save",
        data=json.dumps({"name": args.name}).encode(),
        headers={"Content-Type": "application/json", "X-Cart2d-Token": args.token},
        method="POST",
    )
    try:
        with urllib.request.urlopen(request, timeout=30) as answer:
            saved = json.loads(answer.read())
    except urllib.error.HTTPError as exc:
        detail = json.loads(exc.read() or b"{}").get("detail", exc.reason)
        print(f"cart2d map save: {detail}", file=sys.stderr)
        return 2 if exc.code in (400, 422) else 1
    except (urllib.error.URLError, OSError) as exc:
        print(f"cart2d map save: no gateway answers at {args.url}: {exc}", file=sys.stderr)
        return 1
    counts = saved["counts"]
    kinds = f"{counts['free']} free, {counts['occupied']} occupied and {counts['unknown']} unknown"
    print(f"saved {saved['yaml']}: {kinds} cells of {saved['resolution_m']} m")
    return 0


def add_map_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--map",
        type=Path,
        metavar="FILE.yaml",
        help="a ROS map_server map (e.g. one `cart2d map save` wrote) as the floor plan for this run",
    )


def floor_plan_of(args: argparse.Namespace) -> tuple[OccupancyMap | None, str | None]:
    """The --map file's map (None without it), or the sentence why it cannot be used."""
    if args.map is None:
        return None, None
    try:
        return load_ros_map(args.map), None
    except MapError as exc:
        return None, f"--map {args.map}: {exc}"


def load_floor_plan(gateway: Any, occupancy: OccupancyMap | None, path: Path | None) -> None:
    """The --map file's map as the gateway's floor plan (in the simulator, its walls too)."""
    if occupancy is not None and path is not None:
        gateway.load_floor_plan(occupancy, path.stem, None, False)
