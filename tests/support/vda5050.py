"""A test's side of VDA 5050: a master control on a real mosquitto that keeps every message a
vehicle sends, each checked against the official JSON schemas (tests/data/vda5050/), and sends
orders and instant actions that are checked the same way."""

from __future__ import annotations

import itertools
import json
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jsonschema_rs

from cart2d.fleet import vda5050
from cart2d.fleet.mqtt import Broker, Connection

SCHEMAS = Path(__file__).resolve().parents[1] / "data" / "vda5050"
_validators: dict[str, Any] = {}


def check(topic_name: str, message: dict[str, Any]) -> None:
    """Raises jsonschema_rs.ValidationError if `message` is not a valid `topic_name` message."""
    if topic_name not in _validators:
        schema = json.loads((SCHEMAS / f"{topic_name}.schema").read_text())
        _validators[topic_name] = jsonschema_rs.validator_for(schema, validate_formats=True)
    _validators[topic_name].validate(message)


class Master:
    """Collects what vehicles publish (uagv/v2/+/+/#), by (serialNumber, topic)."""

    def __init__(self, broker: Broker, name: str = "master") -> None:
        self.headers = vda5050.Headers(name)
        self.received: dict[tuple[str, str], list[dict[str, Any]]] = {}
        self.invalid: list[str] = []
        self._since: dict[tuple[str, str], int] = {}  # what wait_for looks at: what came after the last send
        self._changed = threading.Condition()
        self.connection = Connection(broker, f"test-{name}-{time.monotonic_ns()}")
        self.connection.subscribe(f"{vda5050.INTERFACE}/{vda5050.MAJOR}/+/+/+", self._receive)
        self.connection.start()
        assert self.connection.wait(10), "the master did not connect to the broker"

    def _receive(self, topic_name: str, message: dict[str, Any]) -> None:
        where = vda5050.vehicle_of(topic_name)
        if where is None or where[1] in ("order", "instantActions"):
            return
        try:
            check(where[1], message)
        except jsonschema_rs.ValidationError as exc:
            self.invalid.append(f"{topic_name}: {exc}")
        with self._changed:
            self.received.setdefault(where, []).append(message)
            self._changed.notify_all()

    def last(self, serial: str, topic_name: str) -> dict[str, Any] | None:
        with self._changed:
            messages = self.received.get((serial, topic_name), [])
            return messages[-1] if messages else None

    def wait_for(
        self, serial: str, topic_name: str, what: Callable[[dict[str, Any]], bool], timeout_s: float = 10.0
    ) -> dict[str, Any]:
        """The first message on the topic since the last send() that satisfies `what`."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while True:
                start = self._since.get((serial, topic_name), 0)
                for message in self.received.get((serial, topic_name), [])[start:]:
                    if what(message):
                        return message
                left = deadline - time.monotonic()
                if left <= 0:
                    last = self.received.get((serial, topic_name), [])[-1:]
                    raise AssertionError(
                        f"no such {topic_name} from {serial} within {timeout_s} s; last: {last}"
                    )
                self._changed.wait(left)

    def forget(self) -> None:
        with self._changed:
            self.received.clear()
            self._since.clear()

    def send(self, serial: str, topic_name: str, body: dict[str, Any]) -> dict[str, Any]:
        message = {
            **self.headers.header(topic_name),
            "manufacturer": vda5050.MANUFACTURER,
            "serialNumber": serial,
        }
        message.update(body)
        check(topic_name, message)
        with self._changed:
            self._since = {key: len(messages) for key, messages in self.received.items()}
        self.connection.publish(vda5050.topic(serial, topic_name), message)
        return message

    def close(self) -> None:
        self.connection.close()


def order_body(
    order_id: str,
    update_id: int,
    points: list[tuple[str, float, float]],
    first_seq: int = 0,
    released: int = 99,
) -> dict[str, Any]:
    """An order's nodes at `points` (id, x, y) joined by edges; the first `released` nodes the base."""
    nodes: list[dict[str, Any]] = [
        {
            "nodeId": nid,
            "sequenceId": first_seq + 2 * i,
            "released": i < released,
            "nodePosition": {"x": x, "y": y, "mapId": vda5050.MAP_ID},
            "actions": [],
        }
        for i, (nid, x, y) in enumerate(points)
    ]
    edges = [
        {
            "edgeId": f"{a['nodeId']}-{b['nodeId']}",
            "sequenceId": a["sequenceId"] + 1,
            "released": bool(b["released"]),
            "startNodeId": a["nodeId"],
            "endNodeId": b["nodeId"],
            "actions": [],
        }
        for a, b in itertools.pairwise(nodes)
    ]
    return {"orderId": order_id, "orderUpdateId": update_id, "nodes": nodes, "edges": edges}


def instant(action_id: str, kind: str, **params: Any) -> dict[str, Any]:
    action: dict[str, Any] = {"actionId": action_id, "actionType": kind, "blockingType": "NONE"}
    if params:
        action["actionParameters"] = [{"key": k, "value": v} for k, v in params.items()]
    return {"actions": [action]}
