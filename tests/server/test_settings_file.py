"""The settings file (GET/POST /api/settings/file) backs up the firmware's settings with the
gateway's, and restores them; the network address is checked before it is saved."""

from __future__ import annotations

import json
from typing import Any

import pytest

from cart2d.params import setting_id, settings_table
from tests.support.server import Rig

NOT_HERE = "198.51.100.77"


def firmware_values(rig: Rig) -> dict[str, float]:
    return {s["name"]: s["value"] for s in rig.client.get("/api/firmware/settings").json()}


def set_setting(rig: Rig, name: str, value: float) -> None:
    answer = rig.client.put("/api/firmware/settings", json={"id": setting_id(name), "value": value})
    assert answer.status_code == 200, answer.text


def test_the_settings_file_backs_up_and_restores_the_firmwares_settings(rig: Rig) -> None:
    set_setting(rig, "v_max_mps", 0.3)
    set_setting(rig, "pos_phase_kp", 9.5)
    rig.client.put("/api/map/obstacle", json={"x": 1.0, "y": 1.0})
    exported = rig.client.get("/api/settings/file")
    file = exported.json()
    # every setting by its stable id, as the firmware holds it (float32, shortest digits)
    backed_up = {s["id"]: s for s in file["firmware"]["settings"]}
    assert sorted(backed_up) == [int(entry["id"]) for entry in settings_table()]
    assert backed_up[setting_id("v_max_mps")] == {
        "id": setting_id("v_max_mps"),
        "name": "v_max_mps",
        "value": 0.3,
    }
    assert backed_up[setting_id("tol_final_m")]["value"] == 0.005

    set_setting(rig, "v_max_mps", 0.5)
    set_setting(rig, "pos_phase_kp", 8.0)
    rig.client.put("/api/map/obstacle", json={"x": 1.0, "y": 1.0, "present": False})
    answer = rig.client.post("/api/settings/file", content=exported.content)
    assert answer.status_code == 200, answer.text
    restored = answer.json()
    changed = {c["name"]: (c["from"], c["to"]) for c in restored["firmware"]["changed"]}
    assert changed == {"v_max_mps": (0.5, 0.3), "pos_phase_kp": (8.0, 9.5)}
    assert restored["firmware"]["unchanged"] == len(settings_table()) - 2
    assert "2 settings changed (pos_phase_kp 8 → 9.5, v_max_mps 0.5 → 0.3)" in restored["words"]
    assert "save them to EEPROM" in restored["words"]
    assert firmware_values(rig)["v_max_mps"] == 0.3 and firmware_values(rig)["pos_phase_kp"] == 9.5
    assert rig.client.get("/api/map").json()["obstacles"] == [[1.0, 1.0]]
    # the same file again changes nothing
    again = rig.client.post("/api/settings/file", content=exported.content).json()
    assert again["firmware"]["changed"] == [] and "all as in the file" in again["words"]


def test_an_older_file_without_the_firmwares_settings_still_imports(rig: Rig) -> None:
    set_setting(rig, "v_max_mps", 0.4)
    old = {"version": 1, "network": {"host": "127.0.0.1", "port": 8080}, "map": {"obstacles": [[5, 5]]}}
    answer = rig.client.post("/api/settings/file", content=json.dumps(old).encode())
    assert answer.status_code == 200
    assert answer.json()["firmware"] is None and "left as they are" in answer.json()["words"]
    assert firmware_values(rig)["v_max_mps"] == 0.4
    assert rig.client.get("/api/map").json()["obstacles"] == [[1.0, 1.0]]


def with_firmware(rig: Rig, *settings: dict[str, Any]) -> dict[str, Any]:
    file: dict[str, Any] = rig.client.get("/api/settings/file").json()
    file["map"]["obstacles"] = [[2, 2]]
    file["firmware"]["settings"] = list(settings)
    return file


@pytest.mark.parametrize(
    ("settings", "words"),
    [
        (
            [{"id": 6, "value": 9.0}],
            "firmware.settings[0]: v_max_mps = 9 is out of its range, from 0.01 to 1",
        ),
        (
            [{"id": 6, "name": "tol_final_m", "value": 0.3}],
            "firmware.settings[0]: id 6 is v_max_mps, not tol_final_m",
        ),
        (
            [{"id": 6, "value": 0.3}, {"id": 6, "value": 0.4}],
            "firmware.settings[1]: setting id 6 is given twice",
        ),
        ([{"id": 6, "value": "0.3"}], "firmware.settings.0.value"),
        ([{"id": 6}], "firmware.settings.0.value"),
    ],
)
def test_a_file_with_bad_firmware_settings_changes_nothing(
    rig: Rig, settings: list[dict[str, Any]], words: str
) -> None:
    before = firmware_values(rig), rig.client.get("/api/map").json()
    answer = rig.client.post("/api/settings/file", content=json.dumps(with_firmware(rig, *settings)).encode())
    assert answer.status_code == 422 and words in answer.json()["detail"], answer.text
    assert (firmware_values(rig), rig.client.get("/api/map").json()) == before


def test_a_setting_this_firmware_does_not_have_is_skipped_and_said(rig: Rig) -> None:
    file = with_firmware(rig, {"id": 6, "value": 0.35}, {"id": 200, "name": "warp_factor", "value": 9.0})
    answer = rig.client.post("/api/settings/file", content=json.dumps(file).encode()).json()
    assert answer["firmware"]["skipped"] == [
        "setting id 200 (warp_factor) is not one of this firmware's: skipped"
    ]
    assert "Setting id 200 (warp_factor) is not one of this firmware's: skipped." in answer["words"]
    assert firmware_values(rig)["v_max_mps"] == 0.35


def test_an_address_this_machine_does_not_have_is_not_saved(rig: Rig) -> None:
    before = rig.client.get("/api/settings").json()
    answer = rig.client.put("/api/settings/network", json={"host": NOT_HERE, "port": 8080})
    assert answer.status_code == 422
    assert answer.json()["detail"].startswith(f"host: {NOT_HERE} is not an address of this machine (it has ")
    file = {**rig.client.get("/api/settings/file").json(), "network": {"host": NOT_HERE, "port": 8080}}
    imported = rig.client.post("/api/settings/file", content=json.dumps(file).encode())
    assert imported.status_code == 422 and NOT_HERE in imported.json()["detail"]
    assert rig.client.get("/api/settings").json() == before
    assert rig.store.load().network.host == before["network"]["host"]
    for host in ("0.0.0.0", "::", "127.0.0.1", "localhost"):  # every interface, or this machine alone
        assert rig.client.put("/api/settings/network", json={"host": host, "port": 8081}).status_code == 200
        assert rig.store.load().network.host == host


def test_the_api_says_what_the_settings_file_is(rig: Rig) -> None:
    paths = rig.client.get("/openapi.json").json()["paths"]
    summary = paths["/api/settings/file"]["get"]["summary"]
    assert "settings.bin" not in summary and "JSON" in summary and "firmware" in summary
    schema = paths["/api/settings/file"]["post"]["requestBody"]["content"]["application/json"]["schema"]
    assert "firmware" in schema["properties"]
