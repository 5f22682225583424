#!/usr/bin/env python3
"""Generate the C++ header of robot parameters from config/robot.toml.

config/robot.toml is the single source of truth; the firmware and the simulator include the
generated header, the gateway reads the TOML itself. Settings are emitted as an X-macro
list so that core/ can build its tables in flash (not in the AVR's 2 KiB of RAM).
"""

from __future__ import annotations

import argparse
import sys
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from cart2d.spec import crc16_mcrf4xx

SETTING_FIELDS = ("id", "name", "unit", "min", "max", "default", "doc")


def nano_pin(number: int) -> tuple[str, int]:
    """Arduino Nano digital pin -> (AVR port letter, bit)."""
    if 0 <= number <= 7:
        return "D", number
    if 8 <= number <= 13:
        return "B", number - 8
    raise ValueError(f"D{number} is not a digital pin of the Nano")


def cpp_literal(value: object) -> tuple[str, str]:
    if isinstance(value, bool):
        return "bool", "true" if value else "false"
    if isinstance(value, int):
        return "long", f"{value}L"
    if isinstance(value, float):
        return "float", f"{value!r}f"
    raise TypeError(f"unsupported parameter type {type(value).__name__}")


def check(config: dict) -> None:
    pins = config["pins"]
    fixed = {"left_enc_a": 2, "right_enc_a": 3, "left_pwm": 10, "right_pwm": 9}
    for name, number in fixed.items():
        if pins[name] != number:
            raise ValueError(f"pins.{name} must be D{number}: the timers and INT0/INT1 fix it")
    ids = [s["id"] for s in config["setting"]]
    if ids != list(range(len(ids))):
        raise ValueError("setting ids must be 0, 1, 2, ... in order")
    for s in config["setting"]:
        missing = [f for f in SETTING_FIELDS if f not in s]
        if missing:
            raise ValueError(f"setting {s.get('name')} lacks {missing}")
        if not s["min"] <= s["default"] <= s["max"]:
            raise ValueError(f"setting {s['name']}: default outside [min, max]")


def emit_table(name: str, table: dict) -> list[str]:
    """A namespace of constants; a sub-table ([sim.camera]) is a namespace inside it."""
    out = [f"namespace {name} {{"]
    for key, value in table.items():
        if isinstance(value, dict):
            out += emit_table(key, value)
            continue
        ctype, literal = cpp_literal(value)
        out.append(f"constexpr {ctype} {key} = {literal};")
    out.append(f"}}  // namespace {name}\n")
    return out


def emit_tables(config: dict) -> list[str]:
    out: list[str] = []
    for table in ("encoders", "traction", "body", "control", "motor", "caster", "camera", "sim"):
        out += emit_table(table, config[table])
    return out


def emit_pins(config: dict) -> list[str]:
    out = ["namespace pins {", "struct Pin { char port; unsigned char bit; };"]
    for key, number in config["pins"].items():
        port, bit = nano_pin(number)
        out.append(f"constexpr Pin {key} = {{'{port}', {bit}}};  // D{number}")
    out.append("}  // namespace pins\n")
    return out


def emit_settings(settings: list[dict]) -> list[str]:
    layout = ";".join(f"{s['id']}:{s['name']}" for s in settings).encode()
    out = [
        "namespace settings {",
        f"constexpr unsigned char kCount = {len(settings)};",
        f"constexpr unsigned kLayoutHash = 0x{crc16_mcrf4xx(layout):04X}u;  // CRC-16 of ids and names",
        "enum Id : unsigned char {",
    ]
    out += [f"  {s['name']} = {s['id']},  // {s['unit']}: {s['doc']}" for s in settings]
    out.append("};")
    out.append("}  // namespace settings\n")
    out.append("// X(id, name, min, max, default) for every setting, to build tables where they are used.")
    out.append("#define CART2D_SETTINGS(X) \\")
    for s in settings:
        numbers = ", ".join(f"{float(s[k])!r}f" for k in ("min", "max", "default"))
        out.append(f"  X({s['id']}, {s['name']}, {numbers}) \\")
    out.append("")
    return out


def generate(config: dict, source: str) -> str:
    check(config)
    lines = [
        f"// Generated from {source} by tools/gen_params.py. Do not edit.",
        "#pragma once\n",
        "namespace params {\n",
    ]
    lines += emit_tables(config) + emit_pins(config) + emit_settings(config["setting"])
    lines.append("}  // namespace params")
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("toml", type=Path)
    parser.add_argument("header", type=Path)
    args = parser.parse_args()
    config = tomllib.loads(args.toml.read_text())
    text = generate(config, args.toml.name)
    args.header.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.header.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(args.header)
    return 0


if __name__ == "__main__":
    sys.exit(main())
