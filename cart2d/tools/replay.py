"""`cart2d replay FILE [--speed X] [--loop]`: a recording played back into the panel."""

from __future__ import annotations

import argparse
import contextlib
import sys

from cart2d.recording.replay import Player, RecordingError, read_recording
from cart2d.recording.replay_app import create_replay_app
from cart2d.server import addresses, serving


def main_replay(args: argparse.Namespace) -> int:
    try:
        recorded = read_recording(args.file)
    except (RecordingError, OSError) as exc:
        print(f"cart2d replay: {exc}", file=sys.stderr)
        return 2
    host: str = args.host or "127.0.0.1"
    port: int = args.port or 8080
    connections, backlog = serving.descriptor_budget()
    try:
        sock = addresses.open_listener(host, port, backlog)
    except addresses.CannotListen as exc:
        print(f"cart2d replay: {exc}", file=sys.stderr)
        return 1
    with contextlib.closing(sock):
        player = Player(recorded, args.speed, args.loop)
        app = create_replay_app(player, host, args.allow_host)
        shown = f"[{host}]" if ":" in host else host
        print(
            f"replaying {args.file} ({recorded.duration_s:.1f} s, {len(recorded.ws_messages())} messages, "
            f"{args.speed:g}x, from when the panel opens): http://{shown}:{port}/   (Ctrl-C stops)",
            flush=True,
        )
        try:
            serving.serve(app, sock, connections)
        finally:
            player.close()
    return 0
