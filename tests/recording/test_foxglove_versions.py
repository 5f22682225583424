"""Which Foxglove clients can connect to the live view (README, "Foxglove and recordings"): the
Foxglove SDK's server (foxglove-sdk, pinned in pyproject.toml) speaks the WebSocket subprotocol
foxglove.sdk.v1 only. Lichtblick 1.21 and older ask only for the older name of the same protocol,
foxglove.websocket.v1, and are refused at the handshake (issue 22). Should a newer SDK accept
both, this says so, and the README's sentence about Lichtblick can go."""

from __future__ import annotations

import pytest
from websockets.exceptions import InvalidStatus, NegotiationError
from websockets.sync.client import connect

from cart2d.recording import open_recording
from tests.support.recording import StandIn
from tests.support.sockets import free_port


def test_the_live_view_speaks_foxglove_sdk_v1_and_refuses_the_older_name() -> None:
    port = free_port()
    with open_recording(StandIn(), foxglove_port=port):
        url = f"ws://127.0.0.1:{port}"
        with connect(url, subprotocols=["foxglove.sdk.v1"], open_timeout=10) as ws:  # type: ignore[list-item]
            assert ws.subprotocol == "foxglove.sdk.v1"
        with (
            pytest.raises((InvalidStatus, NegotiationError)),
            connect(url, subprotocols=["foxglove.websocket.v1"], open_timeout=10),  # type: ignore[list-item]
        ):
            pass
