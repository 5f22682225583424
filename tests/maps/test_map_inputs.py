"""Bad floor plans and mission files (issue 22): each is refused with a short sentence, checked
before anything runs, never a traceback, a RecursionError, a read without end or a message that
echoes unbounded input. The map and mission parsers' fuzz is tests/maps/test_parser_fuzz.py."""

from __future__ import annotations

import io
import json
import os
import struct
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cart2d.maps import OCCUPIED, MapError, OccupancyMap, load_ros_map, map_from_image, map_from_ros
from cart2d.maps.ros import image_bytes, parse_ros_yaml, ros_yaml
from cart2d.shown import QUOTE_CHARS
from cart2d.simulation.faults import problems as fault_problems
from cart2d.simulation.world import world_file_boxes
from cart2d.simulation.world_file import MAX_PROBLEMS
from cart2d.store import FloorPlan
from cart2d.tools.cli import main
from cart2d.tools.missions.spec import write_report
from tests.support.maps import YAML, alias_bomb

SHORT = 400  # characters: a refusal is a sentence or two, whatever it was sent


def test_a_yaml_alias_bomb_is_refused_at_once_in_a_sentence() -> None:
    # 9 levels: 387 million strings, gigabytes once expanded (7 levels answered 226 MB before)
    text = alias_bomb(9)
    assert len(text) < 700
    started = time.process_time()
    with pytest.raises(MapError, match="alias") as refused:
        parse_ros_yaml(text)
    assert time.process_time() - started < 1.0  # CPU time: nothing was expanded
    assert len(str(refused.value)) < SHORT


def test_yaml_nested_1000_deep_is_refused_in_a_sentence() -> None:
    for nested in ("[" * 1000 + "]" * 1000, "{a: " * 1000 + "1" + "}" * 1000):
        with pytest.raises(MapError, match="nested over") as refused:
            parse_ros_yaml(f"{YAML}extra: {nested}\n")
        assert len(str(refused.value)) < SHORT


@pytest.mark.parametrize(
    "field", ["mode: {}", "negate: {}", "resolution: {}", "origin: [{}, 0, 0]", "occupied_thresh: {}"]
)
def test_a_refusal_quotes_a_value_within_bounds(field: str) -> None:
    huge = "x" * 60_000
    with pytest.raises(MapError) as refused:
        parse_ros_yaml(YAML.replace("origin: [0, 0, 0]\n", "") + field.format(huge) + "\n")
    assert len(str(refused.value)) < SHORT
    assert "x" * QUOTE_CHARS not in str(refused.value)  # a bounded quote: start ... end


def png_chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    chunks, pos = [], 8
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        chunks.append((data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + n]))
        pos += 12 + n
    return chunks


def png_of(chunks: list[tuple[bytes, bytes]]) -> bytes:
    out = b"\x89PNG\r\n\x1a\n"
    for kind, body in chunks:
        out += struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    return out


def test_a_png_whose_second_data_chunk_has_a_damaged_type_is_refused() -> None:
    noise = (np.random.default_rng(1).random((300, 300)) * 255).astype(np.uint8)
    out = io.BytesIO()
    Image.fromarray(noise, mode="L").save(out, "PNG", compress_level=0)
    header, *_ = png_chunks(out.getvalue())
    data = b"".join(body for kind, body in png_chunks(out.getvalue()) if kind == b"IDAT")
    for damaged in (b"ID\x00T", b"ID T", b"\xff\xff\xff\xff"):  # SyntaxError in Pillow, was a 500
        png = png_of([header, (b"IDAT", data[:1000]), (damaged, data[1000:]), (b"IEND", b"")])
        with pytest.raises(MapError, match="cannot be read"):
            map_from_ros(YAML, png)


@pytest.mark.parametrize("fmt", ["DDS", "BMP", "GIF", "TIFF", "WEBP", "JPEG"])
def test_only_the_formats_of_floor_plans_are_taken(fmt: str) -> None:
    out = io.BytesIO()
    Image.new("RGB", (8, 8), (255, 255, 255)).save(out, format=fmt)
    with pytest.raises(MapError, match="not a PNG nor a PGM"):
        map_from_image(out.getvalue(), 0.1)


def test_netpbm_and_png_are_taken() -> None:
    for fmt in ("PNG", "PPM"):
        out = io.BytesIO()
        Image.new("L", (8, 8), 255).save(out, format=fmt)
        assert map_from_image(out.getvalue(), 0.1).counts()["free"] == 64


@pytest.mark.parametrize(
    ("resolution", "written"), [(0.0005, "0.0005"), (1e-300, "1.0e-300"), (10.5, "10.5")]
)
def test_a_resolution_out_of_range_is_refused_in_a_sentence(resolution: float, written: str) -> None:
    image = image_bytes(OccupancyMap((0.0, 0.0), 0.1, np.zeros((4, 4), np.int8)), ".png")
    with pytest.raises(MapError, match=r"resolution must be from 0\.001 to 10"):
        map_from_image(image, resolution)
    with pytest.raises(MapError, match=r"resolution must be from 0\.001 to 10"):
        map_from_ros(YAML.replace("0.1", written), image)


def test_an_origin_past_what_the_settings_keep_is_a_map_error() -> None:
    plan = OccupancyMap((1e7, 0.0), 0.1, np.zeros((4, 4), np.int8))
    with pytest.raises(MapError, match="origin_m"):
        FloorPlan.of(plan)


def test_a_map_file_that_is_no_regular_file_is_refused_without_reading_it(tmp_path: Path) -> None:
    with pytest.raises(MapError, match="not a regular file"):
        load_ros_map(Path("/dev/zero"))  # read until MemoryError before
    fifo = tmp_path / "map.yaml"
    os.mkfifo(fifo)  # opening it for reading waited for a writer
    with pytest.raises(MapError, match="not a regular file"):
        load_ros_map(fifo)
    (tmp_path / "zero.yaml").write_text("image: /dev/zero\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(MapError, match=r"image '/dev/zero' cannot be read: it is not a regular file"):
        load_ros_map(tmp_path / "zero.yaml")
    (tmp_path / "big.yaml").write_bytes(b"#" * (65 * 1024))
    with pytest.raises(MapError, match="over 65536 bytes"):
        load_ros_map(tmp_path / "big.yaml")


def write_mission(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "mission.json"
    path.write_text(text)
    return path


def refused(path: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """What `cart2d mission PATH` printed, having refused with exit status 2 and written nothing."""
    assert main(["mission", str(path)]) == 2
    assert not path.with_name("mission.report.json").exists()
    return capsys.readouterr().err


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ('{"goals": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too deep"),
        ('{"goals": [[1, ' + "9" * 5000 + "]]}", "integer with too many digits"),
        ('{"goals": [[1, 1]], "map": "/dev/zero"}', "not a regular file"),
        ('{"goals": [[1, 1]], "world": {"boxes": [{"x": 1e300, "y": 0, "sx": 0.2, "sy": 0.2}]}}', "100000"),
        ('{"goals": [[1, 1]], "' + "k" * 100_000 + '": 1}', "unknown key"),
        ('{"goals": [[1, 1]], "settings": {"' + "s" * 100_000 + '": 1}}', "unknown firmware setting"),
        ('{"goals": [[1, 1]], "faults": {"' + "f" * 100_000 + '": 1}}', "unknown fault"),
        ('{"goals": [[1, 1]], "map": "' + "m" * 4000 + '.yaml"}', "cannot be read"),
    ],
)
def test_bad_mission_files_exit_2_with_a_short_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, words: str
) -> None:
    said = refused(write_mission(tmp_path, text), capsys)
    assert words in said and len(said) < 2 * SHORT, said


def test_a_mission_lists_its_first_problems_and_counts_the_rest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    said = refused(write_mission(tmp_path, json.dumps({"goals": [["x", "y"]] * 500})), capsys)
    assert said.count("\n") == MAX_PROBLEMS + 1  # the problems, and how many more
    assert f"and {1000 - MAX_PROBLEMS} more problems" in said


def test_a_world_file_is_checked_whole_before_the_simulator_starts(tmp_path: Path) -> None:
    # what `cart2d sim --world` checks before anything starts (exit 2 with these lines); a box the
    # simulator refuses was found only once it ran
    world = tmp_path / "world.json"
    world.write_text(json.dumps({"boxes": [{"x": 1e300, "y": 0.0, "sx": 0.2, "sy": 0.2}]}))
    boxes, problems = world_file_boxes(world)
    assert boxes == [] and len(problems) == 1 and "boxes[0].x" in problems[0] and "100000" in problems[0]
    assert world_file_boxes(Path("/dev/zero"))[1] == [
        "the world file /dev/zero cannot be read: it is not a regular file (a device, a pipe or a socket)"
    ]


def test_fault_problems_quote_within_bounds() -> None:
    said = fault_problems({"x" * 100_000: 1.0, "enc_slip_l": 10**400, "enc_slip_r": "y" * 100_000})
    assert len(said) == 3 and all(len(p) < SHORT for p in said)


def test_a_floor_plan_is_written_and_read_back_within_the_bounds(tmp_path: Path) -> None:
    cells = np.zeros((20, 30), np.int8)
    cells[5, :] = OCCUPIED
    plan = OccupancyMap((-1.0, 2.0), 0.05, cells)
    (tmp_path / "p.pgm").write_bytes(image_bytes(plan))
    (tmp_path / "p.yaml").write_text(ros_yaml(plan, "p.pgm"))
    assert load_ros_map(tmp_path / "p.yaml").same_cells(plan)


def test_a_report_carries_no_float_noise(tmp_path: Path) -> None:
    write_report(tmp_path / "r.json", {"length_m": 0.1 + 0.2, "trace": [[1.2000000000000002, 3.0]]})
    assert json.loads((tmp_path / "r.json").read_text()) == {"length_m": 0.3, "trace": [[1.2, 3.0]]}


def test_a_map_mission_whose_start_is_in_a_wall_is_refused_before_it_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cells = np.zeros((40, 40), np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    plan = OccupancyMap((-2.0, -2.0), 0.1, cells)
    (tmp_path / "room.pgm").write_bytes(image_bytes(plan))
    (tmp_path / "room.yaml").write_text(ros_yaml(plan, "room.pgm"))
    said = refused(
        write_mission(tmp_path, '{"map": "room.yaml", "start": [-1.95, 0, 0], "goals": [[0, 0]]}'), capsys
    )
    assert "start: the cart's position (-1.950, 0.000) is inside a wall of the floor plan" in said
    assert "choose a start on the map's free floor" in said and "POST /api/pose" not in said
