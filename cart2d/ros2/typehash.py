"""A message type's ROS 2 type hash (REP 2011, `RIHS01_<sha256>`) from its declaration in
types.py: what rmw_cyclonedds_cpp (Iron and later) puts in each endpoint's USER_DATA as
`typehash=...;`, which `ros2 topic info -v` shows. The hash is the SHA-256 of the JSON of the
type's description (its fields' names and type ids, nested types by name) and of every type it
refers to, sorted by name (type_description_interfaces; tests/ros2/ check it against rosbags)."""

from __future__ import annotations

import hashlib
import json
import typing
from typing import Any

import cyclonedds.idl.types as cdds
from cyclonedds.idl import IdlStruct

# type_description_interfaces/msg/FieldType's ids: a base type's; +48 its array, +96 its bounded
# sequence, +144 its unbounded sequence.
BASE_IDS = {
    "nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7,
    "int64": 8, "uint64": 9, "float32": 10, "float64": 11, "bool": 15, "byte": 16,
    "string": 17, "bounded_string": 21,
}  # fmt: skip
ARRAY, BOUNDED_SEQUENCE, SEQUENCE = 48, 96, 144


def ros_type_name(kind: type[Any]) -> str:
    """nav_msgs/msg/Odometry for nav_msgs::msg::dds_::Odometry_."""
    package, space, _, message = str(kind.__idl_typename__).split("::")
    return f"{package}/{space}/{message.removesuffix('_')}"


def _field_type(hint: Any, refs: dict[str, dict[str, Any]]) -> dict[str, Any]:
    offset, capacity, string_capacity, nested = 0, 0, 0, ""
    meta = getattr(hint, "__metadata__", (None,))[0]
    if isinstance(meta, cdds.array | cdds.sequence):
        if isinstance(meta, cdds.array):
            offset, capacity = ARRAY, meta.length
        else:
            offset, capacity = (BOUNDED_SEQUENCE, meta.max_length) if meta.max_length else (SEQUENCE, 0)
        hint = meta.subtype
        meta = getattr(hint, "__metadata__", (None,))[0]
    if isinstance(hint, type) and issubclass(hint, IdlStruct):
        base, nested = "nested", ros_type_name(hint)
        _describe(hint, refs)
    elif isinstance(meta, cdds.bounded_str):
        base, string_capacity = "bounded_string", meta.max_length
    elif hint is str or hint is bool:
        base = "string" if hint is str else "bool"
    else:
        base = str(meta)
    return {
        "type_id": BASE_IDS[base] + offset,
        "capacity": capacity,
        "string_capacity": string_capacity,
        "nested_type_name": nested,
    }


def _describe(kind: type[Any], refs: dict[str, dict[str, Any]]) -> dict[str, Any]:
    name = ros_type_name(kind)
    if name not in refs:
        refs[name] = {}  # before its fields: a type refers to itself through none of them
        hints = typing.get_type_hints(kind, include_extras=True)
        fields = [{"name": field, "type": _field_type(hint, refs)} for field, hint in hints.items()]
        refs[name].update({"type_name": name, "fields": fields})
    return refs[name]


_hashes: dict[str, str] = {}  # by DDS type name: the hash of a declaration never changes


def type_hash(kind: type[Any]) -> str:
    name = str(kind.__idl_typename__)
    if name not in _hashes:
        _hashes[name] = _computed(kind)
    return _hashes[name]


def _computed(kind: type[Any]) -> str:
    refs: dict[str, dict[str, Any]] = {}
    description = _describe(kind, refs)
    name = ros_type_name(kind)
    document = {
        "type_description": description,
        "referenced_type_descriptions": [refs[k] for k in sorted(refs) if k != name],
    }
    return "RIHS01_" + hashlib.sha256(json.dumps(document).encode()).hexdigest()
