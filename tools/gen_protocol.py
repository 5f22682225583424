#!/usr/bin/env python3
"""Generate the firmware's protocol header from docs/protocol.md.

The specification's tables (commands, error reasons, modes, flags) are the single source of
truth. The dictionary hash is a CRC-16 over the command table, so a host can refuse to talk to
a firmware built from a different table (COMMAND_VERSION reports it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from cart2d.spec import parse_spec


def enum(name: str, base: str, items: list[tuple[str, int]], prefix: str = "") -> list[str]:
    out = [f"enum {name} : {base} {{"]
    out += [f"  {prefix}{item} = {value}," for item, value in items]
    out.append("};")
    return out


def generate(text: str, source: str) -> str:
    spec = parse_spec(text)
    lines = [
        f"// Generated from {source} by tools/gen_protocol.py. Do not edit.",
        "#pragma once\n",
        "namespace proto {\n",
        f"constexpr unsigned char kVersion = {spec.version};",
        f"constexpr unsigned kDictionaryHash = 0x{spec.dictionary_hash:04X}u;",
        f"constexpr unsigned char kCommandCount = {len(spec.commands)};\n",
    ]
    lines += enum("Command", "unsigned char", [(c.name, c.code) for c in spec.commands.values()])
    counts = [c.arg_count if c.arg_count is not None else 255 for c in spec.commands.values()]
    lines.append("constexpr unsigned char kVariadic = 255;")
    lines.append('// Arguments per command code (the spec\'s "args in" column), kVariadic when it varies.')
    lines.append("#define CART2D_ARG_COUNTS {" + ", ".join(str(n) for n in counts) + "}")
    lines += enum("Reason", "unsigned char", [(n, c) for c, n in spec.reasons.items()], "REASON_")
    lines += enum("Mode", "unsigned char", [(n, c) for c, n in spec.modes.items()], "MODE_")
    lines += enum("Flag", "unsigned", list(spec.flags.items()), "FLAG_")
    lines += enum("ResetCause", "unsigned char", list(spec.reset_causes.items()), "RESET_")
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
