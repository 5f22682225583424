"""A type of another layout under a ROS 2 type name, as a badly built peer would publish (no
`from __future__ import annotations`: cyclonedds resolves the fields' types at run time)."""

from dataclasses import dataclass

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import float64


@final
@dataclass
class ShortTwist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    """A Twist of one number, not six."""

    linear_x: float64 = 0.0
