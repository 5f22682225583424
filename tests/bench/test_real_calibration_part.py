"""The real-calibration part of the bench's "real photographs" section: what add_to puts into the
section it is given (its Markdown, its numbers, its targets), on a stand-in measurement."""

from __future__ import annotations

import pytest

from bench import real_calibration
from bench.common import Section


@pytest.mark.parametrize("ok", [True, False])
def test_the_part_joins_the_section_s_markdown_numbers_and_targets(
    monkeypatch: pytest.MonkeyPatch, ok: bool
) -> None:
    part = real_calibration.Measured("### Real calibration\n", {"fx": 533.0}, [("fx within 0.5 %", ok)])
    monkeypatch.setattr(real_calibration, "measure", lambda quick: part)
    section = Section("real_photographs", "## Real photographs\n", {"detection": {}})
    real_calibration.add_to(section, quick=True)
    assert section.markdown == "## Real photographs\n\n### Real calibration\n"
    assert section.data == {"detection": {}, "calibration": {"fx": 533.0}}
    assert section.targets_met is ok
    missed_before = Section("real_photographs", "", targets_met=False)
    real_calibration.add_to(missed_before, quick=True)
    assert not missed_before.targets_met  # a part never clears what the section missed
