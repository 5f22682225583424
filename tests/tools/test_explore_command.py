"""`cart2d explore` against a stand-in gateway (an HTTP server answering /api/explore as the
gateway does): it prints the progress and the end's sentence, exits 2 with the gateway's
sentence for a refusal, and refuses a bad name before asking."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from cart2d.tools import cli, explore_command


def view(state: str, seen: float, sentence: str = "") -> dict[str, Any]:
    return {
        "type": "exploration",
        "state": state,
        "seen_m2": seen,
        "seen_percent": 10 * seen,
        "frontiers": 3,
        "goals": 2,
        "set_aside": [{"x": 1.0, "y": 2.0, "reason": "no path to the frontier at (1.00, 2.00)"}],
        "elapsed_s": 5.0,
        "elapsed_sim_s": 7.0,
        "sentence": sentence,
        "saved": None,
    }


class Gateway:
    def __init__(self, refuse: str = "") -> None:
        self.refuse = refuse
        self.posts: list[tuple[str, Any]] = []
        self.views = [view("exploring", 1.0), view("exploring", 2.0)]
        self.end = view("finished", 3.0, "exploration finished: no reachable frontier left; map saved")


@pytest.fixture
def gateway() -> Iterator[tuple[Gateway, str]]:
    state = Gateway()

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args: object) -> None:
            pass

        def _answer(self, code: int, body: dict[str, Any]) -> None:
            data = json.dumps(body).encode()
            self.send_response(code)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def do_POST(self) -> None:
            body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
            state.posts.append((self.path, body))
            if state.refuse:
                self._answer(409, {"detail": state.refuse})
            else:
                self._answer(202, view("exploring", 0.0))

        def do_GET(self) -> None:
            self._answer(200, state.views.pop(0) if state.views else state.end)

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        yield state, f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


def test_it_prints_the_progress_and_the_sentence(
    gateway: tuple[Gateway, str], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    state, url = gateway
    monkeypatch.setattr(explore_command, "POLL_S", 0.01)
    assert cli.main(["explore", "--url", url, "--save", "kitchen"]) == 0
    assert state.posts == [("/api/explore", {"save": "kitchen"})]
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("1.0 m² of floor seen (10 % of the arena), 3 frontiers, 1 set aside")
    assert out[1].startswith("2.0 m² of floor seen")
    assert "set aside (1.00, 2.00): no path to the frontier" in out[2]
    assert out[-1] == "exploration finished: no reachable frontier left; map saved"


def test_a_refusal_is_its_sentence_and_status_2(
    gateway: tuple[Gateway, str], capsys: pytest.CaptureFixture[str]
) -> None:
    state, url = gateway
    state.refuse = "a mission is running: stop it or wait for its end, then explore"
    assert cli.main(["explore", "--url", url]) == 2
    assert capsys.readouterr().err == f"cart2d explore: {state.refuse}\n"


def test_a_bad_name_is_refused_before_asking(
    gateway: tuple[Gateway, str], capsys: pytest.CaptureFixture[str]
) -> None:
    state, url = gateway
    assert cli.main(["explore", "--url", url, "--save", "../x"]) == 2
    assert "a map's name is" in capsys.readouterr().err and state.posts == []
