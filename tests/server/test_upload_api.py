"""Floor plans and settings files through the API (issue 22), against the real firmware in the
simulator: a stop answers while an upload or an import is parsed or planned (asserted by the order
of events, with a parser or planner held until the stop has answered: never by the wall clock),
multipart uploads and the guards around them, bad uploads refused in a sentence that never echoes
unbounded input, the cart's pose checked against a new plan, goals in unknown space called so,
and numbers without float noise."""

from __future__ import annotations

import base64
import re
import threading
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from cart2d.gateway.live_map import planner_for
from cart2d.maps import OCCUPIED, UNKNOWN, OccupancyMap
from cart2d.maps.ros import image_bytes, ros_yaml
from cart2d.server import create_app
from cart2d.store import MapSettings, SettingsFile, parse_settings
from tests.support.maps import alias_bomb
from tests.support.server import BASE_URL, JSON, Rig

HELD_S = 30.0  # how long a held parser waits for the stop: only a bound, the order is what is judged
SHORT = 400  # characters: a refusal is a sentence or two, whatever it was sent


@pytest.fixture(scope="module")
def rig(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Rig]:
    r = Rig(tmp_path_factory.mktemp("uploads"))
    yield r
    r.close()


@pytest.fixture
def client(rig: Rig) -> Iterator[TestClient]:
    """One event loop for every request of the test (a TestClient outside `with` makes one each),
    the gateway back on its default map afterwards."""
    with TestClient(
        create_app(rig.gateway, simulation=rig.simulation.add_routes), base_url=BASE_URL, headers=JSON
    ) as c:
        yield c
    rig.gateway.update_settings(rig.gateway.settings.model_copy(update={"map": MapSettings()}))


def room(origin: tuple[float, float] = (-2.0, -2.0), unknown: bool = False) -> OccupancyMap:
    """A 4 x 4 m room at 0.1 m, walls round its edge; optionally unknown space in its upper right."""
    cells = np.zeros((40, 40), dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    if unknown:
        cells[25:35, 25:35] = UNKNOWN
    return OccupancyMap(origin, 0.1, cells)


def plain(plan: OccupancyMap, **fields: Any) -> dict[str, Any]:
    image = base64.b64encode(image_bytes(plan, ".pgm")).decode()
    return {"image": image, "resolution_m": plan.resolution_m, "origin_m": list(plan.origin_m), **fields}


def test_a_stop_answers_while_a_settings_import_is_parsed(
    rig: Rig, client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Parsed on the event loop, a 7 MB file held every request, the stop too, for 2.2 s."""
    parsing, stop_answered = threading.Event(), threading.Event()
    order: list[str] = []

    def held_parse(data: bytes) -> SettingsFile:
        parsing.set()
        stop_answered.wait(HELD_S)
        order.append("parsed")
        return parse_settings(data)

    monkeypatch.setattr("cart2d.server.admin.parse_settings", held_parse)
    exported = client.get("/api/settings/file").content
    imported: list[Any] = []

    def post() -> None:
        imported.append(client.post("/api/settings/file", content=exported))

    importer = threading.Thread(target=post)
    importer.start()
    assert parsing.wait(HELD_S)
    stop = client.post("/api/stop")  # its 200 is the firmware's reply to STOP
    order.append("stop answered")
    stop_answered.set()
    importer.join()
    assert stop.status_code == 200 and imported[0].status_code == 200, imported[0].text
    assert order == ["stop answered", "parsed"]


def test_a_stop_answers_while_a_new_floor_plan_is_planned(
    rig: Rig, client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The planner of a 2000 x 2000 plan takes most of a second: built under the gateway's lock,
    the stop's answer (it ends the mission under that lock) waited for it."""
    planning, stop_answered = threading.Event(), threading.Event()
    order: list[str] = []

    def held_planner(m: MapSettings) -> Any:
        if m.floor_plan is not None and not planning.is_set():
            planning.set()
            stop_answered.wait(HELD_S)
            order.append("planned")
        return planner_for(m)

    monkeypatch.setattr("cart2d.gateway.map_service.planner_for", held_planner)
    uploaded: list[Any] = []

    def post() -> None:
        uploaded.append(client.post("/api/map", json=plain(room())))

    uploader = threading.Thread(target=post)
    uploader.start()
    assert planning.wait(HELD_S)
    stop = client.post("/api/stop")
    order.append("stop answered")
    stop_answered.set()
    uploader.join()
    assert stop.status_code == 200 and uploaded[0].status_code == 200, uploaded[0].text
    assert order == ["stop answered", "planned"]


def test_a_floor_plan_comes_as_multipart_from_the_panel_or_with_the_token_header(
    rig: Rig, client: TestClient
) -> None:
    form = TestClient(client.app, base_url=BASE_URL)  # no JSON content type: httpx writes the form's
    plan = room()
    files = {"image": ("room.pgm", image_bytes(plan, ".pgm"), "image/x-portable-graymap")}
    fields = {"resolution_m": "0.1", "origin_m": "[-2.0, -2.0]", "planning_step_m": "0.2"}
    # a page elsewhere could send this form (a simple request): without proof it is refused
    refused = form.post("/api/map", files=files, data=fields)
    assert refused.status_code == 403 and "X-Cart2d-Token" in refused.json()["detail"]
    version = client.get("/api/map").json()["version"]
    for proof in ({"Origin": BASE_URL}, {"Sec-Fetch-Site": "same-origin"}, {"X-Cart2d-Token": "on loopback"}):
        answer = form.post("/api/map", files=files, data=fields, headers=proof)
        assert answer.status_code == 200, answer.text
        view = answer.json()
        assert view["floor_plan"]["name"] == "room.pgm" and view["floor_plan"]["origin_m"] == [-2.0, -2.0]
        assert view["step_m"] == 0.2 and view["pose_warning"] is None
    assert client.get("/api/map").json()["version"] == version + 3
    # a map_server map: the YAML as a second file
    yaml_file = ("room.yaml", ros_yaml(plan, "room.pgm").encode(), "application/yaml")
    answer = form.post("/api/map", files={**files, "yaml": yaml_file}, headers={"Origin": BASE_URL})
    assert answer.status_code == 200 and answer.json()["floor_plan"]["name"] == "room.pgm"
    # bad forms: a sentence each, and nothing changes
    version = client.get("/api/map").json()["version"]
    own = {"Origin": BASE_URL}
    bad_forms: list[tuple[dict[str, Any], dict[str, str], str]] = [
        (files, {"resolution_m": "a tenth"}, "not a JSON value"),
        (files, {"resolution_m": "0.1", "colour": "1"}, "colour"),
        (files, {"resolution_m": "0.0005"}, "resolution_m"),
        (files, {}, "needs resolution_m"),
        ({"image": (None, "P5 2 2 255")}, {"resolution_m": "0.1"}, "as a file part"),
        ({"image": ("x.dds", b"DDS |" + bytes(200), "image/vnd-ms.dds")}, {"resolution_m": "0.1"}, "PNG"),
    ]
    for bad_files, bad_fields, words in bad_forms:
        answer = form.post("/api/map", files=bad_files, data=bad_fields, headers=own)
        assert answer.status_code == 422 and words in answer.json()["detail"], (bad_fields, answer.text)
    assert client.get("/api/map").json()["version"] == version


def test_bad_uploads_are_refused_in_a_short_sentence(rig: Rig, client: TestClient) -> None:
    version = client.get("/api/map").json()["version"]
    good = plain(room())
    for body, words in [
        ({**good, "resolution_m": 0.0005}, "resolution_m"),  # was accepted, then a 500
        ({**good, "resolution_m": None, "yaml": ros_yaml(room(), "r.pgm").replace("0.1", "0.0005")}, "0.001"),
        ({**good, "yaml": alias_bomb(7)}, "alias"),  # a 226 MB answer, 1 GB of memory
        ({**good, "yaml": "a: " + "[" * 1000 + "]" * 1000}, "nested"),
        ({**good, "yaml": ros_yaml(room(), "r.pgm").replace("trinary", "m" * 60_000)}, "trinary"),
        ({**good, "origin_m": [2e6, 0.0]}, "origin_m"),
        ({**good, "image": "bm90IGFuIGltYWdl"}, "not a PNG nor a PGM"),
        ({**good, "k" * 100_000: 1}, "Extra inputs"),
    ]:
        answer = client.post("/api/map", json=body)
        detail = answer.json()["detail"]
        assert answer.status_code == 422 and words in detail and len(detail) < SHORT, (words, detail[:SHORT])
    assert client.get("/api/map").json()["version"] == version


def test_no_validation_error_echoes_unbounded_input(client: TestClient) -> None:
    for path, body in [
        ("/api/command", {"name": "A" * 200_000, "args": []}),  # the validator quoted the name whole
        ("/api/goto", {"x": 0.0, "y": 0.0, **{f"{k:05}" + "k" * 200: 1 for k in range(1000)}}),
        ("/api/goto", {"x": 0.0, "y": 0.0, "k" * 200_000: 1}),
    ]:
        answer = client.post(path, json=body)
        assert answer.status_code == 422 and len(answer.json()["detail"]) < SHORT, answer.text[:SHORT]
    many = client.post("/api/goto", json={"x": 0.0, "y": 0.0, **{f"k{k}": 1 for k in range(1000)}})
    assert "and 995 more" in many.json()["detail"]


def test_a_plan_that_puts_the_cart_in_a_wall_is_loaded_with_a_warning_that_can_be_followed(
    rig: Rig, client: TestClient
) -> None:
    rig.link.call("SET_POSE", 0.0, 0.0, 0.0)
    # a plain image placed at its default origin: the cart at (0, 0) is at its corner, off its floor
    answer = client.post("/api/map", json=plain(room(origin=(0.0, 0.0))))
    assert answer.status_code == 200
    warning = answer.json()["pose_warning"]
    assert "the cart's position (0.000, 0.000) is off the map" in warning
    assert "Set pose" in warning and "origin" in warning
    # placed so that the cart stands in its bottom wall
    answer = client.post("/api/map", json=plain(room(origin=(-2.0, -0.05))))
    assert answer.status_code == 200
    warning = answer.json()["pose_warning"]
    assert "the cart's position (0.000, 0.000) is inside a wall of the floor plan" in warning
    assert "Set pose" in warning and "origin" in warning and "remove that obstacle" not in warning
    goal = client.post("/api/goto", json={"x": 1.0, "y": 2.0})
    assert goal.status_code == 422 and "set the pose where the cart really stands" in goal.json()["detail"]
    # the pose set where the cart stands on the plan: goals are taken
    assert client.post("/api/pose", json={"x": 1.0, "y": 1.0, "theta": 0.0}).status_code == 200
    rig.sim.control("place", x=1.0, y=1.0)
    assert client.post("/api/goto", json={"x": 1.5, "y": 1.0}).status_code == 200
    assert client.post("/api/stop").status_code == 200
    # or the plan placed where the cart stands: no warning
    assert client.post("/api/map", json=plain(room(origin=(-2.0, -2.0)))).json()["pose_warning"] is None


def test_a_goal_in_unknown_space_is_called_so(rig: Rig, client: TestClient) -> None:
    rig.link.call("SET_POSE", 0.0, 0.0, 0.0)
    assert client.post("/api/map", json=plain(room(unknown=True))).status_code == 200
    answer = client.post("/api/goto", json={"x": 1.0, "y": 1.0})  # in the unknown square
    detail = answer.json()["detail"]
    assert answer.status_code == 422 and "in unknown space" in detail and "unknown_is_free" in detail
    assert "obstacle" not in detail
    wall = client.post("/api/goto", json={"x": -1.95, "y": 0.0})
    assert wall.status_code == 422 and "inside a wall of the floor plan" in wall.json()["detail"]


def test_the_map_and_plans_carry_no_float_noise(rig: Rig, client: TestClient) -> None:
    rig.link.call("SET_POSE", 0.0, 0.0, 0.0)
    # 3 cells of 0.1 m: a planning step of 0.30000000000000004 m, nodes at such coordinates
    answer = client.post("/api/map", json=plain(room(), planning_step_m=0.3))
    assert answer.status_code == 200 and answer.json()["step_m"] == 0.3
    plan = client.post("/api/goto", json={"x": 1.0, "y": 0.7})
    assert plan.status_code == 200
    client.post("/api/stop")
    for text in (client.get("/api/map").text, plan.text, client.get("/api/mission").text):
        assert re.search(r"\d\.\d{10,}", text) is None, text[:SHORT]
