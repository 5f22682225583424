"""The benchmark report fails only on targets that do not depend on the machine's load."""

from __future__ import annotations

import types
from pathlib import Path

import pytest

from bench import report
from bench.common import Section


def _fake_sections(monkeypatch: pytest.MonkeyPatch, sections: dict[str, Section]) -> None:
    def import_module(name: str) -> types.ModuleType:
        module = types.ModuleType(name)
        section = sections[name.removeprefix("bench.")]
        module.run = lambda out, quick: section  # type: ignore[attr-defined]
        return module

    monkeypatch.setattr("bench.report.importlib.import_module", import_module)


def test_a_missed_wall_clock_target_is_reported_and_does_not_fail(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    slow = Section("system", "## System\n", wall_clock_missed=["real-time factor ≥ 10 (8.0)"])
    _fake_sections(monkeypatch, {"system": slow, "planner": Section("planner", "## Planner\n")})
    assert report.main(["--quick", "--out", str(tmp_path), "--only", "system", "planner"]) == 0
    text = (tmp_path / "REPORT.md").read_text()
    assert "| system | met; on this machine's wall clock missed: real-time factor ≥ 10 (8.0) |" in text
    assert "| planner | met |" in text


def test_a_missed_load_independent_target_fails(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    wrong = Section("planner", "## Planner\n", targets_met=False, wall_clock_missed=["1000 x 1000 in 1 s"])
    _fake_sections(monkeypatch, {"planner": wrong})
    assert report.main(["--quick", "--out", str(tmp_path), "--only", "planner"]) == 1
    assert "| planner | **MISSED** |" in (tmp_path / "REPORT.md").read_text()
