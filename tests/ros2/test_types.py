"""The bridge's message types are ROS 2's: each one's bytes equal rosbags' CDR serialization of
the same ROS 2 message (Jazzy's and Kilted's definitions), under rmw_cyclonedds' type name.

The values come from the ROS definition (every field, in its order, distinct values), and each
side builds its message from them by the ROS field names: a field missing, misnamed, of another
size or out of order changes the bytes or fails the build."""

from __future__ import annotations

import dataclasses
import functools
import itertools
import typing
from typing import Any

import cyclonedds.idl.types as cdds
import numpy as np
import pytest
from cyclonedds.core import Policy
from cyclonedds.idl import IdlStruct
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.msg import get_types_from_msg
from rosbags.typesys.store import Typestore

from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.node import with_type_hash
from cart2d.ros2.typehash import type_hash

STORES = [Stores.ROS2_JAZZY, Stores.ROS2_KILTED]
HEADER = "uint64 guid\nint64 seq\n"  # rmw_cyclonedds' request header before a service's fields
# The interfaces rosbags does not carry (std_srvs, action_msgs' services, nav2_msgs), from their
# packages' definitions, with the request header where rmw_cyclonedds puts it.
EXTRA = {
    "std_srvs/srv/Trigger_Request": HEADER + "uint8 structure_needs_at_least_one_member",
    "std_srvs/srv/Trigger_Response": HEADER + "bool success\nstring message",
    "action_msgs/srv/CancelGoal_Request": HEADER + "action_msgs/GoalInfo goal_info",
    "action_msgs/srv/CancelGoal_Response": HEADER
    + "int8 return_code\naction_msgs/GoalInfo[] goals_canceling",
    "nav2_msgs/action/NavigateToPose_Goal": "geometry_msgs/PoseStamped pose\nstring behavior_tree",
    "nav2_msgs/action/NavigateToPose_Result": "uint16 error_code\nstring error_msg",
    "nav2_msgs/action/NavigateToPose_Feedback": "geometry_msgs/PoseStamped current_pose\n"
    "builtin_interfaces/Duration navigation_time\nbuiltin_interfaces/Duration estimated_time_remaining\n"
    "int16 number_of_recoveries\nfloat32 distance_remaining",
    "nav2_msgs/action/NavigateToPose_SendGoal_Request": HEADER
    + "unique_identifier_msgs/UUID goal_id\nnav2_msgs/NavigateToPose_Goal goal",
    "nav2_msgs/action/NavigateToPose_SendGoal_Response": HEADER
    + "bool accepted\nbuiltin_interfaces/Time stamp",
    "nav2_msgs/action/NavigateToPose_GetResult_Request": HEADER + "unique_identifier_msgs/UUID goal_id",
    "nav2_msgs/action/NavigateToPose_GetResult_Response": HEADER
    + "int8 status\nnav2_msgs/NavigateToPose_Result result",
    "nav2_msgs/action/NavigateToPose_FeedbackMessage": "unique_identifier_msgs/UUID goal_id\n"
    "nav2_msgs/NavigateToPose_Feedback feedback",
}
NUMPY = {
    "bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
    "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
    "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64,
}  # fmt: skip


def dds_name(kind: Any) -> str:
    """The type's name on DDS (its IdlStruct typename)."""
    name: str = kind.__idl_typename__
    return name


def ros_name(kind: type[Any]) -> str:
    """nav_msgs/msg/Odometry for nav_msgs::msg::dds_::Odometry_ (rmw_cyclonedds' mangling)."""
    package, space, dds, message = dds_name(kind).split("::")
    assert dds == "dds_" and message.endswith("_"), dds_name(kind)
    return f"{package}/{space}/{message.removesuffix('_')}"


OURS = {
    ros_name(kind): kind
    for kind in vars(t).values()
    if isinstance(kind, type) and kind.__module__ == t.__name__
}


def oracle(name: str) -> str:
    """The name a service's or an action's part has in rosbags' store (under msg/: the names its
    definitions refer to each other by)."""
    return name.replace("/srv/", "/msg/").replace("/action/", "/msg/")


@functools.cache
def typestore(which: Stores) -> Typestore:
    store = get_typestore(which)
    for name, text in EXTRA.items():
        store.register(get_types_from_msg(text, oracle(name)))
    return store


class Values:
    """Distinct values for every field of a ROS message, by its definition."""

    def __init__(self) -> None:
        self._counter = itertools.count(1)

    def base(self, kind: str) -> Any:
        n = next(self._counter)
        if kind == "string":
            return f"frame_{n}"
        if kind == "bool":
            return n % 2 == 1
        if kind.startswith("float"):
            return n + 0.25
        return n % (100 if kind in ("int8", "byte", "char", "uint8") else 30000)

    def message(self, store: Typestore, name: str) -> dict[str, Any]:
        return {field: self.node(store, node) for field, node in store.fielddefs[name][1]}

    def node(self, store: Typestore, node: tuple[Any, Any]) -> Any:
        kind, spec = node
        if kind == Nodetype.BASE:
            return self.base(spec[0])
        if kind == Nodetype.NAME:
            return self.message(store, spec)
        (element, length) = spec
        return [self.node(store, element) for _ in range(length or 3)]


def rosbags_message(store: Typestore, name: str, values: dict[str, Any]) -> Any:
    fields = {}
    for field, (kind, spec) in store.fielddefs[name][1]:
        fields[field] = _rosbags_value(store, kind, spec, values[field])
    return store.types[name](**fields)


def _rosbags_value(store: Typestore, kind: Any, spec: Any, value: Any) -> Any:
    if kind == Nodetype.BASE:
        return value
    if kind == Nodetype.NAME:
        return rosbags_message(store, spec, value)
    (element_kind, element_spec), _ = spec
    if element_kind == Nodetype.BASE and element_spec[0] != "string":
        return np.array(value, dtype=NUMPY[element_spec[0]])
    return [_rosbags_value(store, element_kind, element_spec, v) for v in value]


@pytest.mark.parametrize("which", STORES, ids=lambda s: s.name)
@pytest.mark.parametrize("name", sorted(OURS))
def test_bytes_equal_rosbags_cdr(which: Stores, name: str) -> None:
    store = typestore(which)
    assert oracle(name) in store.types, f"{name} is no ROS 2 type"
    values = Values().message(store, oracle(name))
    ours = build(store, name, values).serialize()
    theirs = bytes(store.serialize_cdr(rosbags_message(store, oracle(name), values), oracle(name)))
    assert ours == theirs


def build(store: Typestore, name: str, values: dict[str, Any]) -> Any:
    """Our message of ROS type `name` from `values`, by the ROS definition's fields."""
    kind = {oracle(ros): ours for ros, ours in OURS.items()}[oracle(name)]
    ours_fields = [f.name for f in dataclasses.fields(kind)]
    ros_fields = [field for field, _ in store.fielddefs[oracle(name)][1]]
    assert ours_fields == ros_fields, f"{kind.__name__}: {ours_fields} != ROS {ros_fields}"
    built = {}
    for field, (node_kind, spec) in store.fielddefs[oracle(name)][1]:
        built[field] = _build_value(store, node_kind, spec, values[field])
    return kind(**built)


def _build_value(store: Typestore, kind: Any, spec: Any, value: Any) -> Any:
    if kind == Nodetype.BASE:
        return value
    if kind == Nodetype.NAME:
        return build(store, spec, value)
    (element_kind, element_spec), _ = spec
    return [_build_value(store, element_kind, element_spec, v) for v in value]


def test_every_type_is_declared_once_under_rmw_names() -> None:
    kinds = list(OURS.values())
    assert len({dds_name(k) for k in kinds}) == len(kinds)
    assert dds_name(t.Odometry) == "nav_msgs::msg::dds_::Odometry_"
    assert dds_name(t.TriggerRequest) == "std_srvs::srv::dds_::Trigger_Request_"


def test_the_same_message_in_kilted_and_jazzy_where_both_define_it() -> None:
    """The definitions the bridge uses are the same in both (a difference would need two types)."""
    jazzy, kilted = typestore(Stores.ROS2_JAZZY), typestore(Stores.ROS2_KILTED)
    for name in OURS:
        assert jazzy.fielddefs[oracle(name)] == kilted.fielddefs[oracle(name)], name


def our_spelling(hint: Any) -> str:
    """A field's type as our declaration gives it to Cyclone's XTypes type object."""
    if isinstance(hint, type) and issubclass(hint, IdlStruct):
        return dds_name(hint)
    if hint is str or hint is bool:
        return {str: "string", bool: "bool"}[hint]
    meta = hint.__metadata__[0]
    if isinstance(meta, str):
        return meta
    if isinstance(meta, cdds.array):
        return f"{our_spelling(meta.subtype)}[{meta.length}]"
    if isinstance(meta, cdds.sequence):
        return f"{our_spelling(meta.subtype)}[{meta.max_length or ''}]"
    assert isinstance(meta, cdds.bounded_str)
    return f"string<={meta.max_length}"


def ros_spelling(store: Typestore, node: tuple[Any, Any]) -> str:
    """The same as ROS's IDL has it (rosidl: a message's `char` is a uint8, its `byte` an octet)."""
    kind, spec = node
    if kind == Nodetype.BASE:
        name, bound = spec
        if name == "string":
            return f"string<={bound}" if bound else "string"
        return "uint8" if name == "char" else str(name)
    if kind == Nodetype.NAME:
        return dds_name({oracle(ros): ours for ros, ours in OURS.items()}[spec])
    element, length = spec
    return f"{ros_spelling(store, element)}[{length or ''}]"


@pytest.mark.parametrize("name", sorted(OURS))
def test_every_field_has_the_idl_type_ros_gives_it(name: str) -> None:
    """Byte for byte is not enough: Cyclone matches a reader and a writer by their XTypes type
    objects too, where an octet is not a uint8 and a bounded string not an unbounded one."""
    store = typestore(Stores.ROS2_JAZZY)
    hints = typing.get_type_hints(OURS[name], include_extras=True)
    for field, node in store.fielddefs[oracle(name)][1]:
        assert our_spelling(hints[field]) == ros_spelling(store, node), f"{name}.{field}"


# The message types of ROS topics (ros_discovery_info's are made without a type hash: Gid's `char`
# is a uint8 on the wire but not in ROS's hash, and no tool asks for it)
MESSAGES = sorted(name for name in OURS if "/msg/" in name and not name.startswith("rmw_dds_common/"))


@pytest.mark.parametrize("which", STORES, ids=lambda s: s.name)
@pytest.mark.parametrize("name", MESSAGES)
def test_the_type_hash_is_ros_2s(which: Stores, name: str) -> None:
    """What rmw_cyclonedds_cpp puts in USER_DATA (REP 2011), against rosbags' computation."""
    assert type_hash(OURS[name]) == typestore(which).hash_rihs01(name)


def test_a_message_topics_endpoints_carry_their_type_hash() -> None:
    profile = with_type_hash(qos.stream(), t.Odometry)
    (user_data,) = [p for p in profile if isinstance(p, Policy.Userdata)]
    assert user_data.data == f"typehash={type_hash(t.Odometry)};".encode()
    assert with_type_hash(qos.requests(), t.TriggerRequest) == qos.requests()
