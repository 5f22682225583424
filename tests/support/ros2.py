"""A ROS 2 graph without ROS for tests/ros2/: participants with the tools' QoS on this test
process's own domain (50-99), on loopback, and waits for samples."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

from cyclonedds.core import Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.names import Ros2Options
from cart2d.ros2.node import participant


def _own_domain() -> int:
    """One domain a test process, so that no other run's bridge talks into this one's: pytest-xdist's
    two workers (gw0, gw1) one even and one odd. Below 100, as the ports of domains above reach
    Linux's ephemeral range (7400 + 250 a domain); the benchmark keeps 49."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    parity = int(worker[2:]) % 2 if worker[2:].isdigit() else 0
    return 50 + 2 * (os.getpid() % 25) + parity


DOMAIN = _own_domain()
GUID = 0x1122334455667788  # a client's request writer, as rmw_cyclonedds puts it in the header
ACTION = "navigate_to_pose/_action"


def options(namespace: str = "") -> Ros2Options:
    return Ros2Options(DOMAIN, namespace, "localhost")


class Peer:
    """Another node on the graph, as a ROS 2 tool would be (its readers and writers)."""

    def __init__(self) -> None:
        self.participant: DomainParticipant = participant(DOMAIN, "localhost")

    def reader(self, name: str, kind: type[Any], qos: Qos) -> DataReader[Any]:
        return DataReader(self.participant, Topic(self.participant, name, kind), qos)

    def writer(self, name: str, kind: type[Any], qos: Qos) -> DataWriter[Any]:
        return DataWriter(self.participant, Topic(self.participant, name, kind), qos)

    def close(self) -> None:
        self.participant.__del__()


def samples(
    reader: DataReader[Any], enough: Callable[[list[Any]], bool], wall_timeout_s: float = 20.0
) -> list[Any]:
    """The samples `reader` takes until enough(them) (an AssertionError after the timeout)."""
    kind = reader.topic.data_type
    got: list[Any] = []
    deadline = time.monotonic() + wall_timeout_s
    while not enough(got):
        if time.monotonic() > deadline:
            raise AssertionError(
                f"{len(got)} samples on {reader.topic.name} in {wall_timeout_s} s: not enough"
            )
        got += [s for s in reader.take(64) if isinstance(s, kind)]
        time.sleep(0.01)
    return got


def matched(writer_or_reader: DataWriter[Any] | DataReader[Any], wall_timeout_s: float = 20.0) -> None:
    """Waits until the endpoint has matched a peer."""
    deadline = time.monotonic() + wall_timeout_s
    get = (
        writer_or_reader.get_matched_subscriptions
        if isinstance(writer_or_reader, DataWriter)
        else writer_or_reader.get_matched_publications
    )
    while not get():
        if time.monotonic() > deadline:
            raise AssertionError(f"{writer_or_reader.topic.name}: no match in {wall_timeout_s} s")
        time.sleep(0.01)


def call(peer: Peer, service: str, request: Any, response: type[Any]) -> Any:
    """Sends `request` on rq/<service>Request as an rmw_cyclonedds client would; the reply that
    comes on rr/<service>Reply with its header (GUID, its seq)."""
    replies = peer.reader(f"rr/{service}Reply", response, qos.requests())
    requests = peer.writer(f"rq/{service}Request", type(request), qos.requests())
    matched(requests)
    matched(replies)
    requests.write(request)
    got = samples(replies, lambda got: any(r.seq == request.seq for r in got), 60.0)
    (reply,) = [r for r in got if r.seq == request.seq]
    assert reply.guid == GUID
    return reply


def send_goal(peer: Peer, goal_id: bytes, x: float, y: float, seq: int) -> t.NavigateToPoseSendGoalResponse:
    goal = t.NavigateToPoseGoal(t.PoseStamped(t.Header(frame_id="map"), t.Pose(t.Point(x, y, 0.0))))
    request = t.NavigateToPoseSendGoalRequest(GUID, seq, t.UUID(goal_id), goal)
    reply: t.NavigateToPoseSendGoalResponse = call(
        peer, f"{ACTION}/send_goal", request, t.NavigateToPoseSendGoalResponse
    )
    return reply
