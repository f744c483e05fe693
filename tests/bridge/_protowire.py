"""A small, independent protobuf decoder for the tests: wire format + the schema's descriptors.

foxglove-sdk advertises a protobuf channel's schema as a serialized ``FileDescriptorSet``; this
module reads that set (the field numbers of ``descriptor.proto`` are fixed by the protobuf
specification) and decodes messages into dicts by field name, without the ``protobuf`` package.
Proto3 leaves out fields at their default value: read them with ``.get(name, default)``.
"""

from __future__ import annotations

import struct
from typing import Any


def _varint(buf: bytes, i: int) -> tuple[int, int]:
    out = shift = 0
    while True:
        b = buf[i]
        i += 1
        out |= (b & 0x7F) << shift
        shift += 7
        if not b & 0x80:
            return out, i


def wire_fields(buf: bytes) -> list[tuple[int, int, Any]]:
    """(field number, wire type, raw value) of every field of one message, in order."""
    out = []
    i = 0
    while i < len(buf):
        key, i = _varint(buf, i)
        num, wt = key >> 3, key & 7
        if wt == 0:
            val, i = _varint(buf, i)
        elif wt == 1:
            val, i = buf[i : i + 8], i + 8
        elif wt == 2:
            n, i = _varint(buf, i)
            val, i = buf[i : i + n], i + n
        elif wt == 5:
            val, i = buf[i : i + 4], i + 4
        else:
            raise ValueError(f"wire type {wt} not supported")
        out.append((num, wt, val))
    return out


def _first(fields: list[tuple[int, int, Any]], num: int, default: Any = None) -> Any:
    return next((v for n, _, v in fields if n == num), default)


def descriptors(fds: bytes) -> dict[str, dict[str, tuple[int, int, int, str]]]:
    """Full message name ('foxglove.Pose') -> field name -> (number, label, type, type_name)."""
    types: dict[str, dict[str, tuple[int, int, int, str]]] = {}

    def message(raw: bytes, prefix: str) -> None:
        f = wire_fields(raw)
        name = f"{prefix}.{_first(f, 1).decode()}"
        fields = {}
        for num, _, val in f:
            if num == 2:  # FieldDescriptorProto
                g = wire_fields(val)
                fields[_first(g, 1).decode()] = (
                    _first(g, 3),
                    _first(g, 4, 1),
                    _first(g, 5),
                    (_first(g, 6) or b"").decode(),
                )
            elif num == 3:  # nested DescriptorProto
                message(val, name)
        types[name] = fields

    for num, _, file in wire_fields(fds):
        if num != 1:
            continue
        f = wire_fields(file)
        package = (_first(f, 2) or b"").decode()
        for n, _, val in f:
            if n == 4:
                message(val, package)
    return types


_SCALAR_PACKED = {1: ("<d", 8), 2: ("<f", 4)}


def _scalar(typ: int, wt: int, val: Any) -> Any:
    if typ == 1:
        return struct.unpack("<d", val)[0]
    if typ == 2:
        return struct.unpack("<f", val)[0]
    if typ == 8:
        return bool(val)
    if typ == 9:
        return val.decode()
    if typ == 12:
        return bytes(val)
    if typ in (3, 4, 5, 13, 14):
        return val
    if typ == 6:
        return struct.unpack("<Q", val)[0]
    if typ == 7:
        return struct.unpack("<I", val)[0]
    raise ValueError(f"field type {typ} not supported")


def decode(buf: bytes, name: str, types: dict[str, dict[str, tuple[int, int, int, str]]]) -> dict:
    """The message ``name`` in ``buf`` as a dict (repeated fields as lists)."""
    spec = types[name]
    by_num = {num: (fname, label, typ, tname) for fname, (num, label, typ, tname) in spec.items()}
    out: dict[str, Any] = {}
    for num, wt, val in wire_fields(buf):
        if num not in by_num:
            continue
        fname, label, typ, tname = by_num[num]
        if typ == 11:
            value: Any = decode(val, tname.lstrip("."), types)
            values = [value]
        elif wt == 2 and typ not in (9, 12):  # packed repeated scalars
            if typ in _SCALAR_PACKED:
                fmt, size = _SCALAR_PACKED[typ]
                values = [
                    struct.unpack(fmt, val[k : k + size])[0] for k in range(0, len(val), size)
                ]
            else:
                values, i = [], 0
                while i < len(val):
                    v, i = _varint(val, i)
                    values.append(v)
        else:
            values = [_scalar(typ, wt, val)]
        if label == 3:
            out.setdefault(fname, []).extend(values)
        else:
            out[fname] = values[-1]
    return out
