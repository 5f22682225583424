"""`cart2d explore [--url URL] [--save NAME]`: asks the running gateway (cart2d sim / serve) to
explore (POST /api/explore), prints its progress (GET /api/explore) until it ends, and its
sentence. Ctrl-C stops the cart (POST /api/stop), which ends exploration with the map saved."""

from __future__ import annotations

import argparse
import json
import sys
import time
import urllib.error
import urllib.request
from typing import Any

from cart2d.gateway.exploration_service import DEFAULT_NAME
from cart2d.gateway.map_saving import checked_name

POLL_S = 1.0
ENDED = ("finished", "stopped", "failed")


class Refused(Exception):
    """The gateway answered 4xx: its sentence."""


def add_explore_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--save",
        default=DEFAULT_NAME,
        metavar="NAME",
        help=f"the map's name at the end: maps/NAME.yaml and NAME.pgm in the gateway's folder "
        f"(default {DEFAULT_NAME})",
    )
    parser.add_argument(
        "--url", default="http://127.0.0.1:8080", help="the gateway's address (default http://127.0.0.1:8080)"
    )
    parser.add_argument(
        "--token", default="", help="the access token, if the gateway listens beyond loopback"
    )


def _call(args: argparse.Namespace, path: str, body: dict[str, Any] | None = None) -> dict[str, Any]:
    """GET (body None) or POST `body`; Refused for a 4xx, URLError/OSError without a gateway."""
    request = urllib.request.Request(
        args.url.rstrip("/") + path,
        data=None if body is None else json.dumps(body).encode(),
        headers={"Content-Type": "application/json", "X-Cart2d-Token": args.token},
        method="GET" if body is None else "POST",
    )
    try:
        with urllib.request.urlopen(request, timeout=30) as answer:
            out: dict[str, Any] = json.loads(answer.read())
            return out
    except urllib.error.HTTPError as exc:
        if 400 <= exc.code < 500:
            raise Refused(json.loads(exc.read() or b"{}").get("detail", exc.reason)) from None
        raise


def progress_line(view: dict[str, Any]) -> str:
    sim = f", {view['elapsed_sim_s']:.0f} s simulated" if view.get("elapsed_sim_s") is not None else ""
    return (
        f"{view['seen_m2']:.1f} m² of floor seen ({view['seen_percent']:.0f} % of the arena), "
        f"{view['frontiers']} frontiers, {len(view['set_aside'])} set aside, {view['goals']} goals, "
        f"{view['elapsed_s']:.0f} s{sim}"
    )


def cmd_explore(args: argparse.Namespace) -> int:
    try:
        checked_name(args.save)
    except ValueError as exc:
        print(f"cart2d explore: --save: {exc}", file=sys.stderr)
        return 2
    try:
        _call(args, "/api/explore", {"save": args.save})
        return _follow(args)
    except Refused as exc:
        print(f"cart2d explore: {exc}", file=sys.stderr)
        return 2
    except (urllib.error.URLError, OSError) as exc:
        print(f"cart2d explore: no gateway answers at {args.url}: {exc}", file=sys.stderr)
        return 1


def _follow(args: argparse.Namespace) -> int:
    last = ""
    while True:
        try:
            view = _call(args, "/api/explore")
            if view["state"] in ENDED:
                for aside in view["set_aside"]:
                    print(f"  set aside ({aside['x']:.2f}, {aside['y']:.2f}): {aside['reason']}")
                print(progress_line(view))
                print(view["sentence"])
                return 0 if view["state"] == "finished" else 1
            line = progress_line(view)
            if line != last:
                print(line, flush=True)
                last = line
            time.sleep(POLL_S)
        except KeyboardInterrupt:
            _call(args, "/api/stop", {})  # a stop always goes first; exploration then ends with the map saved
            print("stopped: waiting for the map to be saved", file=sys.stderr)
