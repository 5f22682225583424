"""The firmware's part of the settings file: every firmware setting by stable id, read for a
download and written back with PARAM_SET from an upload, with what that changed.

A file is checked whole before anything is written: an id this firmware does not have is
skipped and said (a file from another version), a name that does not match its id or a value
outside its range (config/robot.toml) refuses the file."""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any, cast

from cart2d.gateway.core import Gateway
from cart2d.link import CommandRefused, LinkError
from cart2d.params import settings_table
from cart2d.store import FirmwareSettings


def section(gateway: Gateway) -> dict[str, Any] | None:
    """The firmware section of a settings file; None when the firmware cannot be read."""
    try:
        values = gateway.firmware_settings()
    except (LinkError, CommandRefused):
        return None
    return {"settings": [{"id": s["id"], "name": s["name"], "value": s["value"]} for s in values]}


@dataclass
class RestorePlan:
    writes: list[tuple[dict[str, Any], float]] = field(default_factory=list)  # (table entry, value)
    skipped: list[str] = field(default_factory=list)  # sentences


def plan(settings: FirmwareSettings) -> tuple[RestorePlan, list[str]]:
    """What restoring `settings` writes, and the problems that refuse it (sentences)."""
    table = {int(entry["id"]): entry for entry in settings_table()}
    result, problems, seen = RestorePlan(), [], set()
    for k, given in enumerate(settings.settings):
        where = f"firmware.settings[{k}]"
        entry = table.get(given.id)
        if given.id in seen:
            problems.append(f"{where}: setting id {given.id} is given twice")
            continue
        seen.add(given.id)
        if entry is None:
            named = f" ({given.name})" if given.name else ""
            result.skipped.append(f"setting id {given.id}{named} is not one of this firmware's: skipped")
        elif given.name and given.name != entry["name"]:
            problems.append(f"{where}: id {given.id} is {entry['name']}, not {given.name}")
        elif not entry["min"] <= given.value <= entry["max"]:
            problems.append(
                f"{where}: {entry['name']} = {given.value:g} is out of its range, "
                f"from {entry['min']:g} to {entry['max']:g}"
            )
        else:
            result.writes.append((entry, given.value))
    return result, problems


def _same_float32(a: float, b: float) -> bool:
    return struct.pack("<f", a) == struct.pack("<f", b)


def restore(gateway: Gateway, todo: RestorePlan) -> dict[str, Any]:
    """Writes the planned values that differ from the firmware's (PARAM_SET, in RAM: SAVE keeps
    them); what changed, in data and in words. LinkError if the firmware stops answering."""
    current = {int(cast(int, s["id"])): cast(float, s["value"]) for s in gateway.firmware_settings()}
    changed: list[dict[str, Any]] = []
    refused: list[str] = []
    unchanged = 0
    for entry, value in todo.writes:
        before = current[int(entry["id"])]
        if _same_float32(before, value):
            unchanged += 1
            continue
        try:
            after = gateway.write_setting(int(entry["id"]), value)
        except CommandRefused as exc:
            refused.append(f"{entry['name']}: {exc}")
            continue
        changed.append({"id": entry["id"], "name": entry["name"], "from": before, "to": after})
    return {
        "changed": changed,
        "unchanged": unchanged,
        "skipped": todo.skipped,
        "refused": refused,
        "words": _words(changed, unchanged, todo.skipped, refused),
    }


def _words(changed: list[dict[str, Any]], unchanged: int, skipped: list[str], refused: list[str]) -> str:
    def count(n: int, what: str) -> str:
        return f"{n} {what}{'' if n == 1 else 's'}"

    if changed:
        listed = ", ".join(f"{c['name']} {c['from']:g} → {c['to']:g}" for c in changed)
        sentences = [f"The firmware's settings: {count(len(changed), 'setting')} changed ({listed})"]
        sentences[0] += f", {unchanged} already as in the file." if unchanged else "."
        sentences.append("They are in RAM: save them to EEPROM to keep them after a reset.")
    else:
        sentences = [f"The firmware's settings were all as in the file ({count(unchanged, 'setting')})."]
    sentences += [f"{s[0].upper()}{s[1:]}." for s in skipped]
    sentences += [f"Refused: {r}." for r in refused]
    return " ".join(sentences)
