"""Reading a recording back (the `mcap` package): what `cart2d replay` plays and serves.

The JSON channels (channels.py) are the timeline: /cart2d/ws, each /ws message as the panel got
it, and /cart2d/map_view, the map it fetched. Two of the Foxglove channels hold what the panel
fetched apart from them, decoded with their protobuf schemas (mcap-protobuf-support): the floor
plan (/map/floor_plan, a foxglove.Grid, published with each map view) and the camera's JPEG
frames (/camera/image/compressed). Times are seconds from the recording's first message.
"""

from __future__ import annotations

import bisect
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from google.protobuf.message import DecodeError
from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Schema
from mcap.well_known import MessageEncoding
from mcap_protobuf.decoder import DecoderFactory

from cart2d.maps import OccupancyMap
from cart2d.maps.ros import image_bytes
from cart2d.recording.channels import TOPIC_CAMERA, TOPIC_MAP_FLOOR_PLAN, TOPIC_MAP_VIEW, TOPIC_WS

READ_TOPICS = [TOPIC_WS, TOPIC_MAP_VIEW, TOPIC_MAP_FLOOR_PLAN, TOPIC_CAMERA]


class RecordingError(ValueError):
    """A file that is not a cart2d recording, in a sentence for a person."""


@dataclass(frozen=True)
class Frame:
    """A camera frame as recorded: the JPEG (with what perception drew on it) and when it was taken."""

    jpeg: bytes
    stamp_s: float  # the camera's own time (wall clock, s)


@dataclass(frozen=True)
class Entry:
    """One message of the timeline: a /ws message or a map view (a dict), or a camera frame."""

    at_s: float  # from the recording's start
    topic: str
    message: dict[str, Any] | Frame


@dataclass
class Recorded:
    path: Path
    entries: list[Entry] = field(default_factory=list)  # in time order
    floor_plans: dict[int, bytes] = field(default_factory=dict)  # the map view's version: its PNG
    duration_s: float = 0.0

    def __post_init__(self) -> None:
        self._times = [e.at_s for e in self.entries]
        self.kinds = {str(m.get("type")) for m in self.ws_messages()}  # the /ws types it has

    def index_after(self, at_s: float) -> int:
        """The index of the first entry later than at_s."""
        return bisect.bisect_right(self._times, at_s)

    def ws_messages(self) -> list[dict[str, Any]]:
        return [e.message for e in self.entries if e.topic == TOPIC_WS and isinstance(e.message, dict)]

    def first_map_view(self) -> dict[str, Any] | None:
        views = (e.message for e in self.entries if e.topic == TOPIC_MAP_VIEW and isinstance(e.message, dict))
        return next(views, None)

    @property
    def frames(self) -> int:
        return sum(1 for e in self.entries if isinstance(e.message, Frame))

    @property
    def simulated(self) -> bool:
        """A recording of the simulator (its ground truth is there)."""
        return "truth" in self.kinds


def _floor_plan_png(grid: Any) -> bytes:
    """A foxglove.Grid of int8 occupancy cells (channels.occupancy_grid) as the panel's PNG."""
    cells = np.frombuffer(grid.data, dtype=np.int8).reshape(-1, grid.column_count)
    origin = (grid.pose.position.x, grid.pose.position.y)
    return image_bytes(OccupancyMap(origin, grid.cell_size.x, cells.copy()), ".png")


class _JsonDecoders(McapDecoderFactory):
    """The JSON channels' messages as dicts (the protobuf ones are mcap-protobuf-support's)."""

    def decoder_for(self, message_encoding: str, schema: Schema | None) -> Callable[[bytes], Any] | None:
        return json.loads if message_encoding == MessageEncoding.JSON else None


def read_recording(path: Path) -> Recorded:
    """What the replay needs of an MCAP file written by cart2d; RecordingError if it has none."""
    raw: list[tuple[int, str, dict[str, Any] | Frame]] = []
    floor_plans: dict[int, bytes] = {}
    map_version = 0
    try:
        with path.open("rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory(), _JsonDecoders()])
            for _, channel, message, decoded in reader.iter_decoded_messages(
                topics=READ_TOPICS, log_time_order=True
            ):
                if channel.topic == TOPIC_MAP_FLOOR_PLAN:  # published right after its map view
                    floor_plans[map_version] = _floor_plan_png(decoded)
                    continue
                if channel.topic == TOPIC_CAMERA:
                    stamp_s = decoded.timestamp.seconds + decoded.timestamp.nanos / 1e9
                    raw.append((message.log_time, channel.topic, Frame(bytes(decoded.data), stamp_s)))
                    continue
                if channel.topic == TOPIC_MAP_VIEW:
                    map_version = int(decoded.get("version") or 0)
                raw.append((message.log_time, channel.topic, decoded))
    except (
        McapError,
        DecodeError,
        UnicodeDecodeError,
        EOFError,
        ValueError,
        TypeError,
        AttributeError,
    ) as exc:
        raise RecordingError(f"{path} is not a readable MCAP recording ({exc})") from exc
    if not any(topic == TOPIC_WS for _, topic, _ in raw):
        raise RecordingError(f"{path} holds no cart2d messages ({TOPIC_WS}): was it recorded by cart2d?")
    start_ns = raw[0][0]
    entries = [Entry((ns - start_ns) / 1e9, topic, message) for ns, topic, message in raw]
    return Recorded(path, entries, floor_plans, entries[-1].at_s)
