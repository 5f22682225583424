"""`cart2d tags print` and `--markers`: sheets at true size that the detector reads back, and a
bad request refused with a sentence and exit status 2."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from cart2d.gateway.bus import EventBus, SimulatorRestarted
from cart2d.localisation.markers import Marker, MarkerMap, MarkersError, load_markers
from cart2d.localisation.tags import TagDetector
from cart2d.tools import cli
from cart2d.tools.localisation import replace_after_restarts


def test_a_png_sheet_is_at_true_size_and_is_read_back(tmp_path: Path) -> None:
    out = tmp_path / "tag.png"
    assert cli.main(["tags", "print", "7", "--size-mm", "80", "--dpi", "200", "--out", str(out)]) == 0
    image = Image.open(out)
    assert image.info["dpi"] == pytest.approx((200, 200), abs=0.01)
    (seen,) = TagDetector().detect(np.asarray(image.convert("L")))
    assert seen.tag_id == 7
    assert seen.side_px() == pytest.approx(80 / 25.4 * 200, abs=1.0)  # the black square, 80 mm


def test_a_pdf_has_a_page_per_marker_of_the_markers_file(tmp_path: Path) -> None:
    markers = tmp_path / "markers.yaml"
    markers.write_text(
        "markers:\n  - {id: 1, size_m: 0.1, x: 0, y: 0}\n  - {id: 2, size_m: 0.05, x: 1, y: 0}\n"
    )
    out = tmp_path / "tags.pdf"
    assert cli.main(["tags", "print", "--markers", str(markers), "--out", str(out)]) == 0
    boxes = re.findall(rb"MediaBox \[ 0 0 ([0-9.]+) ", out.read_bytes())
    # 12 cells (8 and a margin of 2 on each side) of size/8: 150 mm and 75 mm, in points
    assert sorted(float(b) for b in boxes) == pytest.approx([75 / 25.4 * 72, 150 / 25.4 * 72], abs=0.5)


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["tags", "print", "600", "--out", "x.pdf"], "ids run from 0 to 586"),
        (["tags", "print", "3", "--out", "x.svg"], "must end in .pdf or .png"),
        (["tags", "print", "--out", "x.pdf"], "name ids to print"),
    ],
)
def test_a_bad_request_is_refused_with_a_sentence(
    argv: list[str], said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main([*argv[:-1], str(tmp_path / argv[-1])]) == 2
    assert said in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_a_markers_file_with_an_id_twice_or_a_bad_field_says_so(tmp_path: Path) -> None:
    path = tmp_path / "m.json"
    path.write_text(
        '{"markers": [{"id": 1, "size_m": 0.1, "x": 0, "y": 0}, {"id": 1, "size_m": 0.1, "x": 1, "y": 0}]}'
    )
    with pytest.raises(MarkersError, match="id 1 more than once"):
        load_markers(path)
    path.write_text('{"markers": [{"id": 1, "size_m": -1, "x": 0, "y": 0}]}')
    with pytest.raises(MarkersError, match="size_m"):
        load_markers(path)


def test_the_markers_are_sent_again_to_a_simulator_started_again() -> None:
    sent: list[dict[str, Any]] = []

    class FakeSim:
        def control(self, kind: str, **members: Any) -> dict[str, Any]:
            sent.append({"type": kind, **members})
            return {}

    bus = EventBus()
    markers = MarkerMap((Marker(3, 0.1, 1.0, 0.0, 0.06, 180.0),))
    replace_after_restarts(bus, FakeSim(), markers)
    bus.publish(SimulatorRestarted(1, "it exited", False))
    assert sent == []  # not running: nothing to send to
    bus.publish(SimulatorRestarted(2, "", True))
    assert [m["type"] for m in sent] == ["markers"] and sent[0]["markers"][0]["id"] == 3
