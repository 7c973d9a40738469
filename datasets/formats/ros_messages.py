"""Building ROS messages of a ``rosbags`` type store from plain values (for the bag and MCAP writers).

:func:`message` builds any type the store knows from keyword values, nested messages given as dicts, and every
field not given set to its zero (numbers 0, strings "", fixed arrays of zeros, sequences empty): the ROS 1 and
ROS 2 spellings of one type (a ROS 1 ``Header`` has ``seq``, a ROS 2 ``Marker`` a ``texture``) come out of the one
call. Times are seconds (float) turned into ``(sec, nanosec)`` by :func:`stamp`; planar poses ``(x, y, θ)`` into a
``geometry_msgs/Pose`` dict by :func:`pose2d` (z = 0, the yaw quaternion of :mod:`.tum`).
"""

from __future__ import annotations

import numpy as np

from .tum import yaw_to_quaternion

__all__ = ["message", "stamp", "header", "pose2d"]

_NUMPY = {
    "bool": np.bool_,
    "int8": np.int8,
    "uint8": np.uint8,
    "byte": np.uint8,
    "char": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}


def stamp(t: float) -> dict:
    """A ``builtin_interfaces/Time`` of ``t`` seconds (≥ 0), rounded to the nanosecond."""
    ns = int(round(float(t) * 1e9))
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def header(t: float, frame_id: str) -> dict:
    return {"stamp": stamp(t), "frame_id": frame_id}


def pose2d(x: float, y: float, theta: float) -> dict:
    q = yaw_to_quaternion(float(theta))
    return {
        "position": {"x": float(x), "y": float(y), "z": 0.0},
        "orientation": {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])},
    }


def _value(typestore, node, given):
    kind, detail = node
    name = kind.name
    if name == "BASE":
        base = detail[0]
        if given is not None:
            return given
        return "" if base == "string" else False if base == "bool" else _NUMPY[base](0).item()
    if name == "NAME":
        return message(typestore, detail, **(given or {})) if not hasattr(given, "__msgtype__") else given
    # ARRAY (fixed length) or SEQUENCE
    (inner_kind, inner), length = detail
    if inner_kind.name == "BASE" and inner[0] != "string":
        if given is None:
            return np.zeros(length, dtype=_NUMPY[inner[0]])
        return np.ascontiguousarray(given, dtype=_NUMPY[inner[0]])
    items = list(given) if given is not None else [None] * length
    return [_value(typestore, (inner_kind, inner), item) for item in items]


def message(typestore, msgtype: str, **fields):
    """A ``msgtype`` message of ``typestore`` with ``fields`` (module docstring); unknown field names are an error."""
    _, definition = typestore.fielddefs[msgtype]
    names = {n for n, _ in definition}
    unknown = set(fields) - names
    if unknown:
        raise TypeError(f"{msgtype} has no field {', '.join(sorted(unknown))}")
    return typestore.types[msgtype](**{n: _value(typestore, node, fields.get(n)) for n, node in definition})
