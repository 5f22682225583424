"""Where the bridge is on the ROS 2 graph: its domain, its namespace, the DDS names of its topics
and services (rmw_cyclonedds' mangling: `rt/<topic>`, `rq/<service>Request`, `rr/<service>Reply`),
its frames (prefixed in a namespace, as several carts on one network need) and Cyclone DDS's
configuration for ROS's discovery range."""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

NODE_NAME = "cart2d"
MAX_DOMAIN_ID = 232  # ROS 2's highest domain id on Linux (ports: 7400 + 250 * id must fit)
Range = Literal["localhost", "subnet", "off"]
# A ROS name token: letters, digits, underscores, not starting with a digit (ROS 2 design, "Topic
# and Service name mapping"); a namespace is tokens joined by /.
_NAMESPACE = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")


@dataclass(frozen=True)
class Ros2Options:
    domain_id: int = 0
    namespace: str = ""  # "" or "/cart1", "/fleet/cart1"
    discovery: Range = "subnet"
    # Nav2's base only: no map, map -> odom, plan, goals of its own (Nav2's map_server or
    # slam_toolbox, AMCL and bt_navigator have them)
    base_only: bool = False

    def topic(self, name: str) -> str:
        """The DDS topic of the ROS topic `name` (relative to the namespace)."""
        return f"rt{self.namespace}/{name}"

    def request(self, service: str) -> str:
        return f"rq{self.namespace}/{service}Request"

    def reply(self, service: str) -> str:
        return f"rr{self.namespace}/{service}Reply"

    def frame(self, name: str) -> str:
        """A frame of this cart: `cart1/odom` in namespace /cart1 (`map` is shared: not prefixed)."""
        if name == "map" or not self.namespace:
            return name
        return f"{self.namespace.strip('/')}/{name}"

    @property
    def node_namespace(self) -> str:
        return self.namespace or "/"


def namespace_problem(name: str) -> str | None:
    """Why `name` is not a ROS namespace, in a sentence; None if it is."""
    if name in ("", "/"):
        return None
    shown = name if name.startswith("/") else f"/{name}"
    if not _NAMESPACE.fullmatch(shown.rstrip("/") or "/"):
        return (
            f"{name!r} is not a ROS namespace (letters, digits and _ in names joined by /, none "
            "starting with a digit)"
        )
    return None


def normalized_namespace(name: str) -> str:
    """'/cart1' for 'cart1', 'cart1/' or '/cart1'; '' for the root."""
    stripped = name.strip("/")
    return f"/{stripped}" if stripped else ""


def domain_problem(value: str) -> str | None:
    if not value.isdigit() or int(value) > MAX_DOMAIN_ID:
        return f"{value!r} is not a ROS domain id (a whole number from 0 to {MAX_DOMAIN_ID})"
    return None


def discovery_from_environment(env: Mapping[str, str]) -> Range:
    """ROS_AUTOMATIC_DISCOVERY_RANGE (Iron and later: LOCALHOST, SUBNET, OFF, SYSTEM_DEFAULT),
    else the older ROS_LOCALHOST_ONLY=1; the subnet by default, as ROS's."""
    chosen = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper()
    if chosen == "LOCALHOST":
        return "localhost"
    if chosen == "OFF":
        return "off"
    if chosen in ("SUBNET", "SYSTEM_DEFAULT"):
        return "subnet"
    return "localhost" if env.get("ROS_LOCALHOST_ONLY", "").strip() == "1" else "subnet"


def options_from(
    domain_id: int | None,
    namespace: str | None,
    env: Mapping[str, str] | None = None,
    base_only: bool = False,
) -> Ros2Options:
    """The command line's --ros-domain-id and --ros-namespace over ROS_DOMAIN_ID and the
    discovery range of the environment (checked by the command line first)."""
    env = os.environ if env is None else env
    if domain_id is None:
        from_env = env.get("ROS_DOMAIN_ID", "").strip()
        domain_id = int(from_env) if from_env and domain_problem(from_env) is None else 0
    return Ros2Options(
        domain_id, normalized_namespace(namespace or ""), discovery_from_environment(env), base_only
    )


def cyclone_config(discovery: Range) -> str:
    """Cyclone DDS's configuration for ROS's discovery range, as rmw_cyclonedds_cpp writes its own
    (check_create_domain): participant indices for unicast discovery among the processes of this
    machine; LOCALHOST without multicast and with this machine as its one peer; OFF with a tag no
    other process has (this process's participants only)."""
    indices = "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>"
    if discovery == "subnet":
        return f'<CycloneDDS><Domain Id="any"><Discovery>{indices}</Discovery></Domain></CycloneDDS>'
    if discovery == "localhost":
        return (
            '<CycloneDDS><Domain Id="any"><General><AllowMulticast>false</AllowMulticast></General>'
            f"<Discovery>{indices}"
            '<Peers><Peer address="localhost"/></Peers></Discovery></Domain></CycloneDDS>'
        )
    return (
        '<CycloneDDS><Domain Id="any"><General><AllowMulticast>false</AllowMulticast></General>'
        "<Discovery><ParticipantIndex>none</ParticipantIndex>"
        f"<Tag>cart2d_discovery_off_{os.getpid()}</Tag></Discovery></Domain></CycloneDDS>"
    )
