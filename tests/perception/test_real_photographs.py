"""The detector on real photographs (tests/data/real/, README there): the figures it reaches,
held so that a change that loses ground shows. The issue's targets (90 % of obstacles found,
false hits on at most 3 % of scan lines, no shadow taken for an obstacle) are the bench's
(bench/real_photographs.py, which says MISSED); these are what the detector reaches today on this
set: a low camera, every obstacle 2 to 5 m away near the horizon, off-white walls on a light
floor, a dark mat whose edge looks like an obstacle's foot to the appearance cue."""

from __future__ import annotations

from pathlib import Path

import pytest

from cart2d.perception.annotations import Annotation, Evaluated, annotated, evaluate

REAL = Path(__file__).resolve().parents[1] / "data" / "real"


@pytest.fixture(scope="module")
def results() -> list[Evaluated]:
    notes = annotated(REAL)
    missing = [n.image.name for n in notes if not n.image.exists()]
    assert not missing, f"the real photographs are not in {REAL} (its README says which they are): {missing}"
    return [evaluate(n) for n in notes]


def test_the_set_is_annotated_pictures_of_several_kinds_of_obstacle() -> None:
    notes = annotated(REAL)
    assert len(notes) >= 10
    kinds = {o.kind for n in notes for o in n.obstacles}
    assert len(kinds) >= 4 and sum(len(n.shadows) for n in notes) >= 1
    assert all(n.source.startswith("https://github.com/isl-org/OpenBot/") for n in notes)


def test_obstacles_found_do_not_fall_below_todays(results: list[Evaluated]) -> None:
    found = sum(o.found for r in results for o in r.score.obstacles)
    assert found >= 4  # of 30: 13 %, far from the target of 90 % (bench: MISSED)
    feet = [o.foot_error_px for r in results for o in r.score.obstacles if o.found]
    assert max(feet) <= 8.0  # within the tolerance by construction; the median is about 3 px


def test_false_hits_do_not_rise_above_todays(results: list[Evaluated]) -> None:
    lines = sum(r.score.lines for r in results)
    false_hits = sum(r.score.false_hit_lines for r in results)
    assert false_hits / lines <= 0.6  # 56 % today (target 3 %): the mat's edge, the white tape
    # pictures where the floor is one colour up to the wall keep their floor clear
    clear = {r.annotation.image.name: r.score.false_hit_share for r in results}
    assert clear["openbot_0056.jpg"] <= 0.03 and clear["openbot_0168.jpg"] <= 0.03


def test_at_most_one_shadow_is_taken_for_an_obstacle(results: list[Evaluated]) -> None:
    assert sum(r.score.shadows_taken for r in results) <= 1  # the shade under the bench (bench: MISSED)


def test_an_annotation_that_is_not_one_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "x.json"
    bad.write_text('{"image": "x.jpg"}')
    with pytest.raises(ValueError, match="not an annotation"):
        Annotation.load(bad)
