"""RIHS01 type hashes (REP-2016) of the bridge's message types, computed from their definitions.

ROS 2 Iron and later identify a message type by the SHA-256 of its *type description*: the
type's fields (name and a numeric field-type id, with capacities and the nested type's name)
followed by the descriptions of every type it refers to, sorted by name, written as compact
JSON. rmw_cyclonedds puts ``typehash=RIHS01_<64 hex>;`` into the USER_DATA QoS of every reader
and writer; :func:`user_data` builds that value. Humble sends no hash (and a Humble node does not
interoperate with Iron+ anyway); Jazzy matches endpoints without it but logs a warning.

The description is read from the annotations of the Cyclone DDS classes in
:mod:`velfence.bridge.msgs`, so a field added there changes the hash, and the tests compare the
result with hashes published by ROS 2 itself.
"""

from __future__ import annotations

import hashlib
import json
import typing
from typing import Any

from velfence.errors import InvalidParameter

__all__ = ["FIELD_TYPE_IDS", "rihs01", "type_description", "user_data"]

#: Field type ids of ``type_description_interfaces/msg/FieldType`` for the scalar types the
#: bridge's messages use (a fixed array adds 48, a bounded sequence 96, an unbounded one 144;
#: a nested message is 1).
FIELD_TYPE_IDS: dict[str, int] = {
    "int8": 2,
    "uint8": 3,
    "int16": 4,
    "uint16": 5,
    "int32": 6,
    "uint32": 7,
    "int64": 8,
    "uint64": 9,
    "float32": 10,
    "float64": 11,
    "char": 13,
    "bool": 15,
    "byte": 16,
    "string": 17,
    "bounded_string": 21,
}
_NESTED = 1
_ARRAY, _BOUNDED_SEQUENCE, _SEQUENCE = 48, 96, 144


def _ros_name(cls: type) -> str:
    dds = getattr(cls, "__idl_typename__", None)
    if not isinstance(dds, str) or dds.replace("::", ".").count(".") != 3:
        raise InvalidParameter(
            f"msg_type: expected a ROS 2 message class of velfence.bridge.msgs, got {cls!r}"
        )
    pkg, kind, _dds, name = dds.replace("::", ".").split(".")
    return f"{pkg}/{kind}/{name.removesuffix('_')}"


def _scalar(tp: Any) -> tuple[int, str, type | None]:
    """(type id, nested type name, nested class) of a non-collection annotation."""
    if tp is str:
        return FIELD_TYPE_IDS["string"], "", None
    if typing.get_origin(tp) is typing.Annotated and type(typing.get_args(tp)[1]).__name__ == (
        "bounded_str"
    ):
        return FIELD_TYPE_IDS["bounded_string"], "", None
    if tp is bool:
        return FIELD_TYPE_IDS["bool"], "", None
    if typing.get_origin(tp) is typing.Annotated:
        meta = typing.get_args(tp)[1]
        if isinstance(meta, str) and meta in FIELD_TYPE_IDS:
            return FIELD_TYPE_IDS[meta], "", None
    if isinstance(tp, type) and hasattr(tp, "__idl_typename__"):
        return _NESTED, _ros_name(tp), tp
    raise InvalidParameter(f"msg_type: a field type the type hash does not know: {tp!r}")


def _field(name: str, tp: Any, *, char: bool = False) -> tuple[dict[str, Any], type | None]:
    increment = capacity = string_capacity = 0
    if typing.get_origin(tp) is typing.Annotated:
        meta = typing.get_args(tp)[1]
        kind = type(meta).__name__  # cyclonedds.idl.types.array / sequence
        if kind == "array":
            increment, capacity, tp = _ARRAY, int(meta.length), meta.subtype
        elif kind == "sequence" and meta.max_length:
            increment, capacity, tp = _BOUNDED_SEQUENCE, int(meta.max_length), meta.subtype
        elif kind == "sequence":
            increment, tp = _SEQUENCE, meta.subtype
    type_id, nested, cls = _scalar(tp)
    if type_id == FIELD_TYPE_IDS["bounded_string"]:
        string_capacity = int(typing.get_args(tp)[1].max_length)
    if char and type_id == FIELD_TYPE_IDS["uint8"]:  # ROS char: one byte, its own type id
        type_id = FIELD_TYPE_IDS["char"]
    return {
        "name": name,
        "type": {
            "type_id": type_id + increment,
            "capacity": capacity,
            "string_capacity": string_capacity,
            "nested_type_name": nested,
        },
    }, cls


def _individual(cls: type, seen: dict[str, dict[str, Any]]) -> dict[str, Any]:
    name = _ros_name(cls)
    if name in seen:
        return seen[name]
    hints = typing.get_type_hints(cls, include_extras=True)
    fields = []
    nested: list[type] = []
    chars = getattr(cls, "__ros_char_fields__", ())
    for fname, tp in hints.items():
        if fname.startswith("_") or typing.get_origin(tp) is typing.ClassVar:
            continue
        desc, sub = _field(fname, tp, char=fname in chars)
        fields.append(desc)
        if sub is not None:
            nested.append(sub)
    if not fields:  # ROS gives an empty message one placeholder field
        fields.append(
            {
                "name": "structure_needs_at_least_one_member",
                "type": {
                    "type_id": FIELD_TYPE_IDS["uint8"],
                    "capacity": 0,
                    "string_capacity": 0,
                    "nested_type_name": "",
                },
            }
        )
    desc = {"type_name": name, "fields": fields}
    seen[name] = desc
    for sub in nested:
        _individual(sub, seen)
    return desc


def type_description(msg_type: type) -> dict[str, Any]:
    """The hashed form of a message type's description (REP-2016).

    Args:
        msg_type: A message class of :mod:`velfence.bridge.msgs` (``msgs.Twist``).

    Returns:
        ``{"type_description": {...}, "referenced_type_descriptions": [...]}``: the type's
        fields and those of every type it refers to (directly or not), sorted by type name.

    Raises:
        InvalidParameter: ``msg_type`` is no ROS 2 message class, or uses a field type the hash
            does not cover.
    """
    if not isinstance(msg_type, type):
        raise InvalidParameter(
            f"msg_type: expected a ROS 2 message class of velfence.bridge.msgs, got "
            f"{type(msg_type).__name__}"
        )
    seen: dict[str, dict[str, Any]] = {}
    main = _individual(msg_type, seen)
    refs = [seen[k] for k in sorted(seen) if k != main["type_name"]]
    return {"type_description": main, "referenced_type_descriptions": refs}


def rihs01(msg_type: type) -> str:
    """The RIHS01 type hash of a message type, as ROS 2 Iron+ prints and sends it.

    Args:
        msg_type: A message class of :mod:`velfence.bridge.msgs` (``msgs.Twist``).

    Returns:
        ``"RIHS01_"`` followed by 64 lower-case hex digits (SHA-256 of the description's JSON).

    Raises:
        InvalidParameter: ``msg_type`` is no ROS 2 message class.
    """
    text = json.dumps(type_description(msg_type), separators=(", ", ": "), ensure_ascii=True)
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def user_data(msg_type: type) -> bytes:
    """The USER_DATA QoS value rmw_cyclonedds puts on a reader or writer of ``msg_type``.

    Args:
        msg_type: A message class of :mod:`velfence.bridge.msgs`.

    Returns:
        ``b"typehash=RIHS01_<hex>;"``.

    Raises:
        InvalidParameter: ``msg_type`` is no ROS 2 message class.
    """
    return f"typehash={rihs01(msg_type)};".encode("ascii")
