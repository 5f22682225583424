"""The protocol specification (docs/protocol.md) as data: tables, hashes and test vectors.

The firmware's enums are generated from the same file (tools/gen_protocol.py uses this module),
so the gateway and the firmware cannot disagree on a command code without the dictionary hash
telling.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path


def crc16_mcrf4xx(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/MCRF4XX: poly 0x1021 reflected (0x8408), init 0xFFFF, no final XOR."""
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
    return crc


def markdown_tables(text: str) -> dict[str, list[list[str]]]:
    """Tables of a markdown document, keyed by the text of their first header cell."""
    tables: dict[str, list[list[str]]] = {}
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("|") and i + 1 < len(lines) and lines[i + 1].startswith("|---"):
            header = [c.strip() for c in lines[i].strip("|").split("|")]
            rows = []
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c.strip() for c in lines[i].strip("|").split("|")])
                i += 1
            tables[header[0]] = rows
        else:
            i += 1
    return tables


def dictionary_hash(commands: list[list[str]]) -> int:
    """CRC-16 over the command table's code, name, args and results columns."""
    canonical = ";".join("|".join(row[:4]) for row in commands)
    return crc16_mcrf4xx(canonical.encode())


NO_ARGS = "\u2013"  # the spec's table writes an en dash for "none"


@dataclass(frozen=True)
class Command:
    code: int
    name: str
    args: str
    results: str

    @property
    def arg_count(self) -> int | None:
        """Number of arguments, from the spec's "args in" column; None when it varies."""
        if "…" in self.args:
            return None
        return 0 if self.args in (NO_ARGS, "") else len(self.args.split(","))

    @property
    def result_count(self) -> int:
        """Number of results its OK reply carries, from the spec's "results" column."""
        return 0 if self.results in (NO_ARGS, "") else len(self.results.split(","))


@dataclass(frozen=True)
class Spec:
    version: int
    dictionary_hash: int
    commands: dict[str, Command]
    reasons: dict[int, str]
    modes: dict[int, str]
    flags: dict[str, int]  # name -> bit mask
    reset_causes: dict[str, int]  # name -> bit mask of STATUS reset_cause

    def code(self, name: str) -> int:
        key = name if name in self.commands else f"COMMAND_{name}"
        return self.commands[key].code

    def name_of(self, code: int) -> str:
        for command in self.commands.values():
            if command.code == code:
                return command.name
        return f"UNKNOWN_{code}"


def parse_spec(text: str) -> Spec:
    match = re.search(r"^Protocol version: (\d+)$", text, re.MULTILINE)
    if not match:
        raise ValueError("the protocol spec lacks a 'Protocol version: N' line")
    tables = markdown_tables(text)
    commands = tables["code"]
    codes = [int(row[0]) for row in commands]
    if codes != list(range(len(codes))):
        raise ValueError("command codes must be 0, 1, 2, ... in order")
    return Spec(
        version=int(match.group(1)),
        dictionary_hash=dictionary_hash(commands),
        commands={row[1]: Command(int(row[0]), row[1], row[2], row[3]) for row in commands},
        reasons={int(row[0]): row[1] for row in tables["reason"]},
        modes={int(row[0]): row[1] for row in tables["mode"]},
        flags={row[1]: 1 << int(row[0]) for row in tables["flag bit"]},
        reset_causes={row[1]: 1 << int(row[0]) for row in tables["cause bit"]},
    )


def spec_text() -> str:
    return resources.files("cart2d").joinpath("data/protocol.md").read_text(encoding="utf-8")


@cache
def load_spec() -> Spec:
    return parse_spec(spec_text())


@dataclass
class Vector:
    kind: str
    name: str
    data: bytes
    reply: bytes = b""
    fields: dict[str, str] = field(default_factory=dict)


def _hex(text: str) -> bytes:
    return bytes(int(b, 16) for b in text.split())


def load_vectors(text: str | None = None) -> list[Vector]:
    """The ```vectors block: `kind name : hex [-> hex] | key=value ...` per line."""
    text = spec_text() if text is None else text
    block = text.split("```vectors\n", 1)[1].split("\n```", 1)[0]
    vectors = []
    for line in block.splitlines():
        if not line.strip():
            continue
        head, rest = line.split(" : ", 1)
        kind, name = head.split()
        rest, _, field_text = rest.partition("|")
        fields = dict(kv.split("=", 1) for kv in field_text.split())
        data, _, reply = rest.partition("->")
        vectors.append(Vector(kind, name, _hex(data), _hex(reply), fields))
    return vectors


def repo_file(*parts: str) -> Path:
    """A file of the source tree (tools and tests run from a checkout)."""
    return Path(__file__).resolve().parent.parent.joinpath(*parts)
