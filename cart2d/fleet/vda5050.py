"""VDA 5050 2.1.0 (github.com/VDA5050/VDA5050, release/2.1.0): its topics and message headers.
The JSON schemas the messages are checked against are in tests/data/vda5050/."""

from __future__ import annotations

import datetime
import itertools
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

VERSION = "2.1.0"
MAJOR = "v2"
INTERFACE = "uagv"
MANUFACTURER = "cart2d"
MAP_ID = "arena"  # the one map a gateway plans on (its /api/map)

TOPICS = ("order", "instantActions", "state", "visualization", "connection", "factsheet")


def timestamp(now: datetime.datetime | None = None) -> str:
    """ISO 8601 in UTC with milliseconds, as the schemas' examples write it."""
    moment = now or datetime.datetime.now(datetime.UTC)
    return moment.strftime("%Y-%m-%dT%H:%M:%S.") + f"{moment.microsecond // 1000:03d}Z"


def topic(serial_number: str, name: str, manufacturer: str = MANUFACTURER) -> str:
    """interfaceName/majorVersion/manufacturer/serialNumber/topic (VDA 5050 2.1, 6.5)."""
    return f"{INTERFACE}/{MAJOR}/{manufacturer}/{serial_number}/{name}"


def vehicle_of(topic_name: str) -> tuple[str, str] | None:
    """(serialNumber, topic) of a vehicle's topic, None for another."""
    parts = topic_name.split("/")
    if len(parts) != 5 or parts[0] != INTERFACE or parts[1] != MAJOR:
        return None
    return parts[3], parts[4]


@dataclass
class Headers:
    """The header of every message a party sends: headerId counted per topic."""

    serial_number: str
    manufacturer: str = MANUFACTURER
    _counters: defaultdict[str, Iterator[int]] = field(
        default_factory=lambda: defaultdict(lambda: itertools.count(0))
    )

    def header(self, topic_name: str) -> dict[str, Any]:
        return {
            "headerId": next(self._counters[topic_name]),
            "timestamp": timestamp(),
            "version": VERSION,
            "manufacturer": self.manufacturer,
            "serialNumber": self.serial_number,
        }


def error(error_type: str, description: str, level: str = "WARNING", **references: str) -> dict[str, Any]:
    """An entry of state.errors (errorLevel WARNING or FATAL), with its references."""
    entry: dict[str, Any] = {"errorType": error_type, "errorLevel": level, "errorDescription": description}
    if references:
        entry["errorReferences"] = [{"referenceKey": k, "referenceValue": v} for k, v in references.items()]
    return entry
