"""A fuzz of the map and mission parsers (issue 22): valid map_server YAML, images (PGM and PNG, and
the DDS, TIFF, BMP and GIF that Pillow would open too) and mission files, mutated (bits flipped, bytes
inserted and cut, runs repeated, YAML and JSON tokens spliced in, a value replaced by a hostile one:
an alias bomb's alias, nesting 1000 or 100 000 deep, a 5000-digit integer, 1e300, /dev/zero; a PNG's
chunks damaged with their checksums made right again so that the damage gets past the checksum),
must each end in a map or a clean refusal: a MapError, or the mission's problems, every message
short. Never another exception (a 500 or a traceback), never a message that echoes the input at
length.

Seeded and bounded: Hypothesis derandomized (the same inputs every run), no example database,
EXAMPLES inputs per parser; a few seconds in all. Hypothesis' files go under build/hypothesis."""

from __future__ import annotations

import io
import json
import struct
import zlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.configuration import set_hypothesis_home_dir
from PIL import Image

from cart2d.maps import OCCUPIED, UNKNOWN, MapError, OccupancyMap, map_from_image, map_from_ros
from cart2d.maps.ros import image_bytes, ros_yaml
from cart2d.spec import repo_file
from cart2d.tools.missions.run import check_mission

set_hypothesis_home_dir(repo_file("build", "hypothesis"))

EXAMPLES = 200
SHORT = 600  # characters: the longest refusal a mutated input may get
FUZZ = settings(
    max_examples=EXAMPLES,
    derandomize=True,
    database=None,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
# What parsers choke on: YAML anchors and aliases, tags, deep nesting, numbers past a float, NULs,
# bytes that are not UTF-8, JSON's constants that are not JSON
TOKENS = [
    b"&a ",
    b"*a",
    b"<<: *a\n",
    b"!!python/object/apply:os.system ['true']",
    b"!!binary ",
    b"[" * 40,
    b"{a: " * 40,
    b"1e999",
    b"-1e-999",
    b"9" * 5000,
    b"NaN",
    b"Infinity",
    b"\x00",
    b"\xff\xfe",
    b'"',
    b"\n- ",
    b": ",
    b"null",
    b"true",
    b"[[1, 2], [3, 4]]",
]


def room() -> OccupancyMap:
    cells = np.zeros((40, 40), dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    cells[25:35, 25:35] = UNKNOWN
    return OccupancyMap((-2.0, -2.0), 0.1, cells)


def other_format(fmt: str) -> bytes:
    out = io.BytesIO()
    Image.fromarray(np.full((8, 8), 200, dtype=np.uint8), mode="L").convert("RGB").save(out, format=fmt)
    return out.getvalue()


# A value put in place of one of a file's: YAML's anchors (PRELUDE, a bomb of 9**6 strings once
# expanded) and its other hostile values; JSON's
ALIASES = b"".join(
    [b"a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n"]
    + [f"a{k}: &a{k} [{', '.join([f'*a{k - 1}'] * 9)}]\n".encode() for k in range(1, 6)]
)
YAML_VALUES = [
    b"*a5",
    b"[*a5, *a5]",
    b"[" * 1000 + b"]" * 1000,
    b"{a: " * 1000 + b"1" + b"}" * 1000,
    b"x" * 20_000,
    b"1.0e999",
    b".nan",
    b"-.inf",
    b"0.0005",
    b"!!binary AAAA",
    b"!!python/name:os.system",
    b"[1, 2, 3, 4]",
    b"~",
    b"/dev/zero",
]
JSON_VALUES = [
    b"9" * 5000,
    b"[" * 100_000 + b"]" * 100_000,
    b"1e300",
    b"-1e300",
    b"1e-300",
    b"1e999",
    b'"/dev/zero"',
    b'"' + b"x" * 100_000 + b'"',
    b"null",
    b"true",
    b"[]",
    b"{}",
    b'{"' + b"k" * 10_000 + b'": 1}',
    b"[1e300, 0]",
    b"0.0005",
]

ROOM = room()
YAML = ros_yaml(ROOM, "room.pgm")
PGM = image_bytes(ROOM, ".pgm")
PNG = image_bytes(ROOM, ".png")
OTHER_IMAGES = [other_format(fmt) for fmt in ("DDS", "TIFF", "BMP", "GIF")]
MISSION = json.dumps(
    {
        "grid": {"cols": 10, "rows": 10, "step": 0.2},
        "start": [0.2, 0.2, 0.0],
        "goals": [[1.6, 1.6], [0.4, 1.2]],
        "obstacles": [[0.8, 0.8]],
        "settings": {"v_max_mps": 0.4},
        "faults": {"enc_slip_l": 0.01},
        "events": [{"at_s": 1.0, "add": [[1.0, 1.0]]}],
        "world": {"boxes": [{"x": 1.2, "y": 0.4, "sx": 0.2, "sy": 0.2}]},
        "timeout_s": 60,
    },
    indent=1,
).encode()
MAP_MISSION = json.dumps(
    {"map": "room.yaml", "start": [0.0, 0.0, 0.0], "goals": [[1.0, -1.0]], "planning_step": 0.2}, indent=1
).encode()


@st.composite
def mutated(draw: st.DrawFn, seed: bytes) -> bytes:
    """`seed` with one to eight mutations."""
    data = bytearray(seed)
    for _ in range(draw(st.integers(1, 8))):
        kind = draw(st.sampled_from(["flip", "insert", "cut", "token", "repeat"]))
        at = draw(st.integers(0, len(data)))
        if kind == "flip" and data:
            data[min(at, len(data) - 1)] ^= 1 << draw(st.integers(0, 7))
        elif kind == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=8))
        elif kind == "cut":
            del data[at : at + draw(st.integers(1, 64))]
        elif kind == "token":
            data[at:at] = draw(st.sampled_from(TOKENS))
        else:
            run = bytes(data[at : at + draw(st.integers(1, 32))])
            data[at:at] = run * draw(st.integers(2, 200))
    return bytes(data)


@st.composite
def hostile_value(draw: st.DrawFn, seed: bytes, values: list[bytes], prelude: bytes = b"") -> bytes:
    """`seed` (one value a line: YAML, or JSON indented) with one line's value replaced by one of
    `values`, after `prelude` or not, and maybe mutated on top."""
    lines = seed.split(b"\n")
    k = draw(st.integers(0, len(lines) - 1))
    line = lines[k]
    key, colon, _ = line.partition(b": ")
    indent = b" " * (len(line) - len(line.lstrip()))
    comma = b"," if line.rstrip().endswith(b",") else b""
    lines[k] = (key + colon if colon else indent) + draw(st.sampled_from(values)) + comma
    data = draw(st.sampled_from([b"", prelude])) + b"\n".join(lines)
    return draw(st.one_of(st.just(data), mutated(data)))


def png_chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    chunks, pos = [], 8
    while pos + 8 <= len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        chunks.append((data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + n]))
        pos += 12 + n
    return chunks


@st.composite
def damaged_png(draw: st.DrawFn) -> bytes:
    """PNG with image data in several chunks, one chunk's type or body mutated (or a chunk
    repeated, dropped), every checksum right."""
    rows = np.asarray(np.random.default_rng(draw(st.integers(0, 9))).integers(0, 256, (40, 40)), np.uint8)
    header, *_ = png_chunks(PNG)
    compressed = zlib.compress(_filtered(rows))
    cut = draw(st.integers(1, max(1, len(compressed) - 1)))
    chunks = [header, (b"IDAT", compressed[:cut]), (b"IDAT", compressed[cut:]), (b"IEND", b"")]
    k = draw(st.integers(0, len(chunks) - 1))
    kind, body = chunks[k]
    change = draw(st.sampled_from(["type", "body", "repeat", "drop"]))
    if change == "type":
        kind = draw(st.binary(min_size=4, max_size=4))
    elif change == "body":
        body = draw(mutated(body))
    if change == "drop":
        del chunks[k]
    else:
        chunks[k] = (kind, body)
        if change == "repeat":
            chunks.insert(k, (kind, body))
    out = b"\x89PNG\r\n\x1a\n"
    for kind, body in chunks:
        out += struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    return out


def _filtered(rows: np.ndarray) -> bytes:
    """8-bit grey rows with PNG's filter byte 0 before each."""
    return b"".join(b"\x00" + row.tobytes() for row in rows)


def refused_cleanly(action: object) -> None:
    """Runs `action` (a callable): a map, or a MapError with a short message."""
    assert callable(action)
    try:
        action()
    except MapError as exc:
        assert 0 < len(str(exc)) < SHORT, str(exc)[:SHORT]


@FUZZ
@given(st.one_of(mutated(YAML.encode()), hostile_value(YAML.encode(), YAML_VALUES, ALIASES)))
def test_mutated_map_yaml_is_read_or_refused_cleanly(text: bytes) -> None:
    refused_cleanly(lambda: map_from_ros(text.decode("utf-8", "replace"), PGM))


@FUZZ
@given(st.one_of(*(mutated(seed) for seed in (PGM, PNG, *OTHER_IMAGES)), st.sampled_from(OTHER_IMAGES)))
def test_mutated_images_are_read_or_refused_cleanly(data: bytes) -> None:
    refused_cleanly(lambda: map_from_ros(YAML, data))
    refused_cleanly(lambda: map_from_image(data, 0.05))


@FUZZ
@given(damaged_png())
def test_pngs_with_damaged_chunks_are_read_or_refused_cleanly(data: bytes) -> None:
    refused_cleanly(lambda: map_from_image(data, 0.05))


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A folder with a map_server map (room.yaml, room.pgm) for the missions that name it."""
    path = tmp_path_factory.mktemp("fuzz")
    (path / "room.yaml").write_text(YAML)
    (path / "room.pgm").write_bytes(PGM)
    yield path


@FUZZ
@given(
    st.one_of(
        *(mutated(seed) for seed in (MISSION, MAP_MISSION)),
        *(hostile_value(seed, JSON_VALUES) for seed in (MISSION, MAP_MISSION)),
    )
)
def test_mutated_missions_are_taken_or_refused_cleanly(folder: Path, data: bytes) -> None:
    mission = folder / "mission.json"
    mission.write_bytes(data)
    spec, problems = check_mission(mission, folder / "report.json")  # no exception, whatever the file
    assert (spec is None) == bool(problems)
    assert all(0 < len(p) < SHORT for p in problems), [p[:SHORT] for p in problems]
