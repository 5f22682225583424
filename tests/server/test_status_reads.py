"""Reads do not starve the stop (issue 22: 100 concurrent GET /api/status held the stop 0.8-1.1 s,
each read making two exchanges on the link from the server's shared thread pool). /api/status
answers from what the gateway last read (gateway/status_cache.py), and the stop runs in threads
of its own (server/motion.py, Stopper); reads take turns on the event loop (server/reads.py).
Judged by counts and by order, not by time."""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from cart2d.link import Link
from cart2d.server.reads import READS_AT_ONCE
from cart2d.spec import load_spec
from tests.support.live import Http, LiveGateway
from tests.support.waiting import wait_for

READERS = 100


@pytest.fixture
def live(tmp_path: Path) -> Iterator[LiveGateway]:
    gateway = LiveGateway(tmp_path)
    yield gateway
    gateway.close()


def count_requests(link: Link, monkeypatch: pytest.MonkeyPatch) -> Counter[str]:
    """The requests the link sends from now on, by command name."""
    sent: Counter[str] = Counter()
    request = link.request

    def counted(command: str | int, *args: Any, **kwargs: Any) -> Any:
        name = load_spec().name_of(command) if isinstance(command, int) else command
        sent[name.removeprefix("COMMAND_")] += 1
        return request(command, *args, **kwargs)

    monkeypatch.setattr(link, "request", counted)
    return sent


def read_all(live: LiveGateway, count: int) -> tuple[list[threading.Thread], list[tuple[int, Any]]]:
    """`count` clients, each GET /api/status once, all at once; their answers as they come."""
    answers: list[tuple[int, Any]] = []
    clients = [live.http() for _ in range(count)]

    def read(client: Http) -> None:
        answers.append(client.call("GET", "/api/status"))
        client.close()

    threads = [threading.Thread(target=read, args=(c,), daemon=True) for c in clients]
    for thread in threads:
        thread.start()
    for client in clients:
        assert client.sent.wait(20), "a read was not sent"
    return threads, answers


def test_concurrent_status_reads_make_no_exchange_on_the_link(
    live: LiveGateway, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The monitor, which keeps the cache fresh a few times a second, is stopped: every request
    # counted from now on would be one a read made.
    live.gateway.close()
    before = live.http().call("GET", "/api/status")[1]
    sent = count_requests(live.link, monkeypatch)
    threads, answers = read_all(live, READERS)
    for thread in threads:
        thread.join(60)
    assert len(answers) == READERS and {status for status, _ in answers} == {200}
    assert all(body["status"] == before["status"] and body["pose"] == before["pose"] for _, body in answers)
    assert not sent, sent  # before: a STATUS and a POSE for each read


def test_a_stop_is_answered_while_reads_wait(live: LiveGateway, monkeypatch: pytest.MonkeyPatch) -> None:
    """A hundred reads held (the gateway's lock taken, as by planning: the status is then read in
    the server's thread pool): those let in wait inside, the others for their turn (reads.py);
    the stop, sent after all of them, is answered before any of them."""
    release = threading.Event()
    inside: list[int] = []
    status_view = live.gateway.status_view

    def held() -> dict[str, Any]:
        inside.append(1)
        release.wait(60)
        return status_view()

    monkeypatch.setattr(live.gateway, "status_view", held)
    with live.gateway._lock:
        threads, answers = read_all(live, READERS)
        try:
            wait_for(lambda: len(inside) >= READS_AT_ONCE, 30)
            status, body = Http(live.port, timeout_s=20).call("POST", "/api/stop")
            assert status == 200 and body == {"result": "stopped"}
            assert not answers  # not one read was answered before the stop
            assert len(inside) == READS_AT_ONCE  # the others wait for their turn, not in a thread
        finally:
            release.set()
    for thread in threads:
        thread.join(60)
    assert len(answers) == READERS and {status for status, _ in answers} == {200}


def test_after_a_save_the_status_shows_the_save(live: LiveGateway) -> None:
    """/api/status answers from the last STATUS read; the gateway reads one after a SAVE, so from
    the SAVE's answer on it shows the SAVE, never the STATUS from before it: the EEPROM busy
    (the firmware writes the record in the background, ~280 simulated ms) or, once the record
    has landed, the settings from the EEPROM. Which of the two depends on how far the simulator
    (`speed max`) ran before the gateway's read: on a busy machine, past the write."""
    live.gateway.close()  # no monitor: the only STATUS read is the one the SAVE makes
    client = live.http()
    before = client.call("GET", "/api/status")[1]["status"]
    assert before["eeprom_busy"] is False and before["settings_source"] == "defaults (blank EEPROM)"
    assert client.call("POST", "/api/firmware/save")[0] == 200
    after = client.call("GET", "/api/status")[1]["status"]
    assert after["uptime_s"] > before["uptime_s"]
    assert after["eeprom_busy"] or after["settings_source"] == "eeprom", after


def test_the_pose_comes_with_telemetry_and_is_read_only_while_telemetry_is_off(
    live: LiveGateway, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Keeping /api/status fresh costs the link no POSE while telemetry comes (25 Hz, the pose in
    every frame); the monitor reads POSE only while it does not."""
    sent = count_requests(live.link, monkeypatch)
    wait_for(lambda: sent["STATUS"] >= 10, 30)  # ten rounds of the monitor
    assert sent["POSE"] == 0
    assert live.http().call("GET", "/api/status")[1]["pose"] == pytest.approx(
        dict(zip(("x", "y", "theta"), live.link.call("POSE"), strict=True))
    )
    live.link.call("TELEMETRY", 0)
    wait_for(lambda: sent["POSE"] >= 3, 30)
