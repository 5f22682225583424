"""The bridge's DDS participant as a ROS 2 node: its writers and readers under rmw_cyclonedds'
names, and `ros_discovery_info` (rmw_dds_common's ParticipantEntitiesInfo), which names the node
and its endpoints for `ros2 node list` and `ros2 node info`."""

from __future__ import annotations

import logging
import threading
from typing import Any

from cyclonedds.core import Entity, Policy, Qos
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.names import NODE_NAME, Range, Ros2Options, cyclone_config
from cart2d.ros2.typehash import type_hash

log = logging.getLogger(__name__)

DISCOVERY_TOPIC = "ros_discovery_info"  # no rt/ prefix: rmw avoids ROS's conventions for it
_domains: dict[int, tuple[Domain, Range]] = {}  # Cyclone configures a domain once a process
_domains_lock = threading.Lock()


def participant(domain_id: int, discovery: Range) -> DomainParticipant:
    """A participant in `domain_id`, its domain configured for `discovery` by the first one made
    in this process (a later one with another range gets the first's, with a warning)."""
    with _domains_lock:
        if domain_id not in _domains:
            _domains[domain_id] = (Domain(domain_id, cyclone_config(discovery)), discovery)
        elif _domains[domain_id][1] != discovery:
            log.warning("domain %d keeps its %s discovery in this process", domain_id, _domains[domain_id][1])
    return DomainParticipant(domain_id)


def gid(entity: Entity) -> t.Gid:
    """An entity's ROS gid: its DDS GUID's 16 bytes (rmw_cyclonedds' convert_guid_to_gid)."""
    return t.Gid(entity.guid.bytes)


def with_type_hash(profile: Qos, kind: type[Any]) -> Qos:
    """A message topic's endpoint QoS with `typehash=RIHS01_...;` in its USER_DATA, as
    rmw_cyclonedds_cpp's (services' and actions' parts carry none: ROS hashes them as services)."""
    if "::msg::" not in str(kind.__idl_typename__):
        return profile
    return profile + Qos(Policy.Userdata(f"typehash={type_hash(kind)};".encode()))


class RosNode:
    """One participant in `options`' domain, one node named `cart2d` in its namespace."""

    def __init__(self, options: Ros2Options, name: str = NODE_NAME) -> None:
        self.options = options
        self.name = name
        self.participant = participant(options.domain_id, options.discovery)
        self._topics: dict[tuple[str, str], Topic[Any]] = {}
        self._readers: list[DataReader[Any]] = []
        self._writers: list[DataWriter[Any]] = []
        self._lock = threading.Lock()
        self._discovery = DataWriter(
            self.participant, self._topic(DISCOVERY_TOPIC, t.ParticipantEntitiesInfo), qos.latched()
        )

    def _topic(self, dds_name: str, kind: type[Any]) -> Topic[Any]:
        key = (dds_name, kind.__name__)
        if key not in self._topics:
            self._topics[key] = Topic(self.participant, dds_name, kind)
        return self._topics[key]

    def writer(self, dds_name: str, kind: type[Any], profile: Qos) -> DataWriter[Any]:
        writer = DataWriter(self.participant, self._topic(dds_name, kind), with_type_hash(profile, kind))
        with self._lock:
            self._writers.append(writer)
        return writer

    def reader(self, dds_name: str, kind: type[Any], profile: Qos) -> DataReader[Any]:
        reader = DataReader(self.participant, self._topic(dds_name, kind), with_type_hash(profile, kind))
        with self._lock:
            self._readers.append(reader)
        return reader

    def announce(self) -> None:
        """Publishes the node and its endpoints (again after adding some)."""
        with self._lock:
            node = t.NodeEntitiesInfo(
                node_namespace=self.options.node_namespace,
                node_name=self.name,
                reader_gid_seq=[gid(r) for r in self._readers],
                writer_gid_seq=[gid(w) for w in self._writers],
            )
        self._discovery.write(t.ParticipantEntitiesInfo(gid(self.participant), [node]))

    def close(self) -> None:
        """Deletes the participant and everything in it (its peers see the node go)."""
        with self._lock:
            self._readers.clear()
            self._writers.clear()
        self.participant.__del__()  # cyclonedds deletes an entity's children with it
