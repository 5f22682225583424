#!/usr/bin/env python3
"""Generate the firmware's protocol header from docs/protocol.md.

The specification's tables (commands, error reasons, modes, flags) are the single source of
truth. The dictionary hash is a CRC-16 over the command table, so a host can refuse to talk to
a firmware built from a different table (COMMAND_VERSION reports it).
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from gen_params import crc16_mcrf4xx


def markdown_tables(text: str) -> dict[str, list[list[str]]]:
    """Tables keyed by the text of their first header cell."""
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
    canonical = ";".join("|".join(row[:4]) for row in commands)
    return crc16_mcrf4xx(canonical.encode())


def protocol_version(text: str) -> int:
    match = re.search(r"^Protocol version: (\d+)$", text, re.MULTILINE)
    if not match:
        raise ValueError("docs/protocol.md lacks a 'Protocol version: N' line")
    return int(match.group(1))


def enum(name: str, base: str, items: list[tuple[str, int]], prefix: str = "") -> list[str]:
    out = [f"enum {name} : {base} {{"]
    out += [f"  {prefix}{item} = {value}," for item, value in items]
    out.append("};")
    return out


def generate(text: str, source: str) -> str:
    tables = markdown_tables(text)
    commands = tables["code"]
    codes = [int(row[0]) for row in commands]
    if codes != list(range(len(codes))):
        raise ValueError("command codes must be 0, 1, 2, ... in order")
    lines = [
        f"// Generated from {source} by tools/gen_protocol.py. Do not edit.",
        "#pragma once\n",
        "namespace proto {\n",
        f"constexpr unsigned char kVersion = {protocol_version(text)};",
        f"constexpr unsigned kDictionaryHash = 0x{dictionary_hash(commands):04X}u;",
        f"constexpr unsigned char kCommandCount = {len(commands)};\n",
    ]
    lines += enum("Command", "unsigned char", [(row[1], int(row[0])) for row in commands])
    lines += enum("Reason", "unsigned char", [(row[1], int(row[0])) for row in tables["reason"]], "REASON_")
    lines += enum("Mode", "unsigned char", [(row[1], int(row[0])) for row in tables["mode"]], "MODE_")
    lines += enum("Flag", "unsigned", [(row[1], 1 << int(row[0])) for row in tables["flag bit"]], "FLAG_")
    lines.append("\n}  // namespace proto")
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("spec", type=Path)
    parser.add_argument("header", type=Path)
    args = parser.parse_args()
    text = generate(args.spec.read_text(), args.spec.name)
    args.header.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.header.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(args.header)
    return 0


if __name__ == "__main__":
    sys.exit(main())
