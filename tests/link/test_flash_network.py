"""The gateway's firmware update over a network link (issue 15): avrdude takes a raw TCP port as
`net:HOST:PORT`, so a link on `socket://HOST:PORT` is flashed through it (Debian's ser2net in
front of the simulated Nano's pty stands for the bridge: its opening the device resets the Nano
into Optiboot, as on a Nano's USB port); avrdude 7.1 has no RFC 2217, so an update on an
`rfc2217://` link is refused before anything starts, with what to do."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from cart2d.link.bootloader import UpdateRefused, avrdude_port
from cart2d.link.built import default_firmware
from cart2d.server import create_app
from tests.support.network_link import NetRig
from tests.support.server import BASE_URL, JSON, OCTETS
from tests.support.waiting import wait_for

HEX = default_firmware().with_suffix(".hex")


@pytest.mark.parametrize(
    ("port", "expected"),
    [
        ("/dev/ttyUSB0", "/dev/ttyUSB0"),
        ("socket://cart.local:6638", "net:cart.local:6638"),
        ("socket://192.168.4.1:23?logging=debug", "net:192.168.4.1:23"),
        ("socket://[fe80::1]:2001", "net:fe80::1:2001"),  # avrdude splits at the last colon
    ],
)
def test_avrdude_gets_the_links_port_in_its_own_words(port: str, expected: str) -> None:
    assert avrdude_port(port) == expected


@pytest.mark.parametrize("port", ["rfc2217://cart.local:2000", "loop://", "socket://cart.local"])
def test_a_port_avrdude_cannot_use_is_refused_with_what_to_do(port: str) -> None:
    with pytest.raises(UpdateRefused, match=r"avrdude cannot flash through .*: .* and update again$"):
        avrdude_port(port)


@pytest.fixture
def net(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[tuple[NetRig, TestClient]]:
    rig = NetRig(tmp_path, rfc2217=request.param)
    client = TestClient(
        create_app(rig.gateway, simulation=rig.simulation.add_routes), base_url=BASE_URL, headers=JSON
    )
    yield rig, client
    rig.close()


def job_of(client: TestClient) -> dict[str, Any]:
    job: dict[str, Any] = client.get("/api/firmware/update").json()
    return job


@pytest.mark.parametrize("net", [False], ids=["socket"], indirect=True)
def test_an_update_over_a_raw_tcp_bridge_flashes_through_avrdudes_net_port(
    net: tuple[NetRig, TestClient],
) -> None:
    rig, client = net
    assert rig.sim.process is not None
    pid = rig.sim.process.pid
    response = client.post("/api/firmware/update", content=HEX.read_bytes(), headers=OCTETS)
    assert response.status_code == 202, response.text
    wait_for(lambda: job_of(client)["state"] != "running", 120)
    job = job_of(client)
    assert job["state"] == "done", job["log"]
    command = next(line for line in job["log"] if "avrdude" in line and "-c arduino" in line)
    assert f"-P net:127.0.0.1:{rig.bridge.port} " in command, command
    assert any("bytes of flash verified" in line for line in job["log"]), job["log"]
    assert rig.sim.process.pid == pid
    status = client.get("/api/status").json()
    assert status["link"]["state"] == "connected" and status["firmware"]["firmware"] == "0.1.0"
    assert status["link"]["port"] == rig.bridge.url  # the gateway is back on its socket:// link


@pytest.mark.parametrize("net", [True], ids=["rfc2217"], indirect=True)
def test_an_update_over_rfc2217_is_refused_with_what_to_do(net: tuple[NetRig, TestClient]) -> None:
    rig, client = net
    opens = rig.link.opens
    response = client.post("/api/firmware/update", content=HEX.read_bytes(), headers=OCTETS)
    assert response.status_code == 409, response.text
    detail = response.json()["detail"]
    assert detail.startswith(
        f"avrdude cannot flash through {rig.bridge.url} because it does not speak RFC 2217"
    )
    assert "socket://HOST:PORT" in detail and detail.count(". ") == 0  # one sentence
    assert job_of(client) == {"state": "idle", "error": "", "log": [], "elapsed_s": 0.0}  # nothing started
    assert rig.link.opens == opens and rig.link.connected.is_set()  # the link was never lent out
