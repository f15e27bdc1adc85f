"""ROS 2 message classes for the DDS backend, generated at run time from the rosbags type store.

``get_message("nav_msgs/msg/OccupancyGrid")`` returns a Cyclone DDS ``IdlStruct`` dataclass whose
DDS type name is ``nav_msgs::msg::dds_::OccupancyGrid_`` (as rmw_cyclonedds_cpp names it) and
whose fields mirror the ROS 2 Jazzy definition, so any std/geometry/nav/sensor/rosgraph/diagnostic
message works without a hand-written mirror. The classes behave like rclpy's:

* every field has a default (zeros, empty string, default-constructed nested message), and the
  constructor takes keyword arguments: ``Float64(data=1.0)``;
* sequences of numbers are ``array.array`` (``msg.data``), fixed-size arrays of numbers are numpy
  arrays (``msg.pose.covariance``), ``byte`` fields are ``bytes`` of length 1, as in rclpy;
  assignment accepts any sequence (list, numpy array, ``array.array``, ``bytes``);
* constants are class attributes (``DiagnosticStatus.OK == b"\\x00"``);
* ``get_fields_and_field_types()`` reports fields in rclpy's format.

Serialization is Cyclone's own Python CDR serializer (XCDR1, little endian), with the machines
for numeric sequences and arrays replaced by bulk ``tobytes``/``frombytes`` ones: a 100x100
``OccupancyGrid`` then costs one memory copy instead of 10 000 Python-level values.
"""

from __future__ import annotations

import array
import dataclasses
import re
import sys
import threading
from functools import cache
from typing import Any, cast

import numpy as np
from cyclonedds.idl import IdlMeta, IdlStruct
from cyclonedds.idl import types as idl
from cyclonedds.idl._machinery import (
    ArrayMachine,
    PlainCdrV2ArrayOfPrimitiveMachine,
    PlainCdrV2SequenceOfPrimitiveMachine,
    PrimitiveMachine,
    SequenceMachine,
    StructMachine,
)
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.base import Nodetype

from wildfire_msgs_py.errors import UnknownMessageTypeError

# ROS base type -> (IDL annotation, array.array code or None, numpy dtype or None, default).
_BASE_TYPES: dict[str, tuple[Any, str | None, str | None, Any]] = {
    "bool": (bool, None, None, False),
    "byte": (idl.byte, "B", "u1", b"\x00"),
    "char": (idl.uint8, "B", "u1", 0),
    "int8": (idl.int8, "b", "i1", 0),
    "uint8": (idl.uint8, "B", "u1", 0),
    "int16": (idl.int16, "h", "<i2", 0),
    "uint16": (idl.uint16, "H", "<u2", 0),
    "int32": (idl.int32, "i", "<i4", 0),
    "uint32": (idl.uint32, "I", "<u4", 0),
    "int64": (idl.int64, "q", "<i8", 0),
    "uint64": (idl.uint64, "Q", "<u8", 0),
    "float32": (idl.float32, "f", "<f4", 0.0),
    "float64": (idl.float64, "d", "<f8", 0.0),
    "string": (str, None, None, ""),
}

# Cyclone's array/sequence make field annotations at run time (``idl.array[T, N]``); mypy knows
# them only inside annotations (through cyclonedds' plugin), so they are called through Any here.
_idl_array: Any = idl.array
_idl_sequence: Any = idl.sequence

# Default values declared in the .msg files of common_interfaces (the type store drops them).
_FIELD_DEFAULTS: dict[tuple[str, str], Any] = {("geometry_msgs/msg/Quaternion", "w"): 1.0}

_TYPE_NAME = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)/(?:msg/)?([A-Z][A-Za-z0-9]*)$")
_DDS_TYPE_NAME = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)::msg::dds_::([A-Za-z0-9]+)_$")
_BUILD_LOCK = threading.RLock()
_LITTLE_ENDIAN = sys.byteorder == "little"


@cache
def typestore() -> Any:
    """The rosbags ROS 2 Jazzy type store (definitions and reference serializer)."""
    return get_typestore(Stores.ROS2_JAZZY)


def normalize_type_name(type_name: str) -> str:
    """``nav_msgs/OccupancyGrid`` (or already ``nav_msgs/msg/OccupancyGrid``) -> full name."""
    match = _TYPE_NAME.match(type_name.strip())
    if not match:
        raise UnknownMessageTypeError(
            f"message type {type_name!r}: expected pkg/msg/Type, e.g. std_msgs/msg/String"
        )
    return f"{match.group(1)}/msg/{match.group(2)}"


def dds_type_name(type_name: str) -> str:
    """ROS type to DDS type name: ``std_msgs/msg/String`` -> ``std_msgs::msg::dds_::String_``."""
    package, _, name = normalize_type_name(type_name).split("/")
    return f"{package}::msg::dds_::{name}_"


def ros_type_name(dds_name: str) -> str | None:
    """DDS type name back to the ROS type (``None`` for a name not made by a ROS 2 rmw)."""
    match = _DDS_TYPE_NAME.match(dds_name)
    return f"{match.group(1)}/msg/{match.group(2)}" if match else None


def message_definition(type_name: str) -> str:
    """The ``ros2msg`` text of a type with its dependencies (as rosbag2 stores it)."""
    return typestore().generate_msgdef(normalize_type_name(type_name), ros_version=2)[0]


def get_message(type_name: str) -> Any:
    """Message class for a ROS 2 type name; raises :class:`UnknownMessageTypeError`."""
    name = normalize_type_name(type_name)
    if name not in typestore().fielddefs:
        raise UnknownMessageTypeError(
            f"message type {type_name!r} is not a ROS 2 Jazzy type known here "
            "(expected a common_interfaces type such as nav_msgs/msg/OccupancyGrid)"
        )
    with _BUILD_LOCK:
        return _build(name)


def is_message(value: Any) -> bool:
    """True for an instance of a generated class."""
    return isinstance(value, IdlStruct) and hasattr(type(value), "_ros_type")


# --- bulk machines -------------------------------------------------------------------------------


def _as_bytes(value: Any, code: str, dtype: str) -> bytes:
    """Bytes of a numeric sequence in little-endian ``dtype`` (bulk, no per-element loop)."""
    if isinstance(value, array.array) and value.typecode == code and _LITTLE_ENDIAN:
        return value.tobytes()
    if isinstance(value, bytes | bytearray | memoryview) and np.dtype(dtype).itemsize == 1:
        return bytes(value)
    return np.asarray(value).astype(dtype, copy=False).tobytes()


class _NumericSequenceMachine(PlainCdrV2SequenceOfPrimitiveMachine):
    """``sequence<number>`` as one block copy; deserializes to ``array.array`` like rclpy."""

    def __init__(self, idl_type: Any, code: str, dtype: str) -> None:
        super().__init__(idl_type)
        self.array_code = code
        self.dtype = dtype

    def serialize(self, buffer: Any, value: Any, *_: Any, **__: Any) -> None:
        data = _as_bytes(value, self.array_code, self.dtype)
        buffer.align(4)
        buffer.write("I", 4, len(data) // self.size)
        if data:
            buffer.align(self.alignment)
            buffer.write_bytes(data)

    def deserialize(self, buffer: Any, *_: Any, **__: Any) -> array.array[Any]:
        buffer.align(4)
        length = buffer.read("I", 4)
        values = array.array(self.array_code)
        if length:
            buffer.align(self.alignment)
            values.frombytes(buffer.read_bytes(length * self.size))
            if buffer._endian != "<":  # big-endian sender (never rmw_cyclonedds on x86/arm)
                values.byteswap()
        return values

    def default_initialize(self) -> array.array[Any]:
        return array.array(self.array_code)


class _NumericArrayMachine(PlainCdrV2ArrayOfPrimitiveMachine):
    """``number[N]`` as one block copy; deserializes to a numpy array like rclpy."""

    def __init__(self, idl_type: Any, length: int, code: str, dtype: str) -> None:
        super().__init__(idl_type, length)
        self.array_code = code
        self.dtype = dtype

    def serialize(self, buffer: Any, value: Any, *_: Any, **__: Any) -> None:
        data = _as_bytes(value, self.array_code, self.dtype)
        if len(data) != self.size:
            raise ValueError(
                f"expected {self.length} values, got {len(data) // (self.size // self.length)}"
            )
        buffer.align(self.alignment)
        buffer.write_bytes(data)

    def deserialize(self, buffer: Any, *_: Any, **__: Any) -> np.ndarray:
        buffer.align(self.alignment)
        dtype = np.dtype(self.dtype).newbyteorder(buffer._endian)
        return np.frombuffer(buffer.read_bytes(self.size), dtype=dtype).astype(self.dtype)

    def default_initialize(self) -> np.ndarray:
        return np.zeros(self.length, dtype=self.dtype)


class _OctetMachine(PrimitiveMachine):
    """ROS ``byte``: one octet on the wire, ``bytes`` of length 1 in Python (as rclpy)."""

    def __init__(self) -> None:
        super().__init__(idl.byte)

    def serialize(self, buffer: Any, value: Any, *_: Any, **__: Any) -> None:
        if isinstance(value, bytes | bytearray):
            value = value[0] if value else 0
        buffer.write("B", 1, int(value))

    def deserialize(self, buffer: Any, *_: Any, **__: Any) -> bytes:
        return bytes((buffer.read("B", 1),))

    def default_initialize(self) -> bytes:
        return b"\x00"


def _install_bulk_machines(cls: Any, fields: list[tuple[str, Any]]) -> None:
    """Swap Cyclone's per-element machines of numeric sequences/arrays for bulk ones."""
    idl_info = cls.__idl__
    idl_info.populate()
    machine = idl_info.v1_machine
    assert isinstance(machine, StructMachine)
    for field_name, (node_type, detail) in fields:
        current = machine.members_machines[field_name]
        if node_type == Nodetype.BASE and detail[0] == "byte":
            machine.members_machines[field_name] = _OctetMachine()
            continue
        if node_type not in (Nodetype.SEQUENCE, Nodetype.ARRAY):
            continue
        (sub_type, sub_detail), count = detail
        if sub_type != Nodetype.BASE:
            continue
        idl_type, code, dtype, _ = _BASE_TYPES[sub_detail[0]]
        if code is None or dtype is None:
            continue
        if node_type == Nodetype.SEQUENCE and isinstance(
            current, SequenceMachine | PlainCdrV2SequenceOfPrimitiveMachine
        ):
            machine.members_machines[field_name] = _NumericSequenceMachine(idl_type, code, dtype)
        elif node_type == Nodetype.ARRAY and isinstance(
            current, ArrayMachine | PlainCdrV2ArrayOfPrimitiveMachine
        ):
            machine.members_machines[field_name] = _NumericArrayMachine(
                idl_type, count, code, dtype
            )


# --- class generation ----------------------------------------------------------------------------


def _rclpy_field_type(node_type: Any, detail: Any) -> str:
    """Field type as rclpy's ``get_fields_and_field_types`` spells it."""
    if node_type == Nodetype.BASE:
        name, bound = detail
        base = {"float32": "float", "float64": "double", "byte": "octet", "char": "uint8"}.get(
            name, name
        )
        return f"{base}<={bound}" if bound and name == "string" else base
    if node_type == Nodetype.NAME:
        package, _, name = detail.split("/")
        return f"{package}/{name}"
    (sub_type, sub_detail), count = detail
    inner = _rclpy_field_type(sub_type, sub_detail)
    if node_type == Nodetype.ARRAY:
        return f"{inner}[{count}]"
    return f"sequence<{inner}, {count}>" if count else f"sequence<{inner}>"


def _default_factory(node_type: Any, detail: Any) -> Any:
    """A zero-argument callable making the default value of one field."""
    if node_type == Nodetype.BASE:
        default = _BASE_TYPES[detail[0]][3]
        return lambda: default
    if node_type == Nodetype.NAME:
        return _build(detail)
    (sub_type, sub_detail), count = detail
    code = _BASE_TYPES[sub_detail[0]][1] if sub_type == Nodetype.BASE else None
    if node_type == Nodetype.SEQUENCE:
        if code is not None:
            return lambda: array.array(code)
        return list
    if code is not None:
        dtype = _BASE_TYPES[sub_detail[0]][2]
        return lambda: np.zeros(count, dtype=dtype)
    element = _default_factory(sub_type, sub_detail)
    return lambda: [element() for _ in range(count)]


def _annotation(node_type: Any, detail: Any) -> Any:
    """Cyclone IDL annotation of one field."""
    if node_type == Nodetype.BASE:
        if detail[0] not in _BASE_TYPES:
            raise UnknownMessageTypeError(f"field type {detail[0]!r} is not supported")
        return _BASE_TYPES[detail[0]][0]
    if node_type == Nodetype.NAME:
        return _build(detail)
    (sub_type, sub_detail), count = detail
    inner = _annotation(sub_type, sub_detail)
    if node_type == Nodetype.ARRAY:
        return _idl_array[inner, count]
    return _idl_sequence[inner, count] if count else _idl_sequence[inner]


_CLASSES: dict[str, Any] = {}


def _build(type_name: str) -> Any:
    """Generate (once) the class of ``pkg/msg/Type`` and of every type it uses."""
    if type_name in _CLASSES:
        return _CLASSES[type_name]
    constants, fields = typestore().fielddefs[type_name]
    package, _, name = type_name.split("/")
    namespace = cast(
        "dict[str, Any]",
        IdlMeta.__prepare__(name, (IdlStruct,), typename=f"{package}::msg::dds_::{name}_"),
    )
    for field_name, (node_type, detail) in fields:
        namespace["__annotations__"][field_name] = _annotation(node_type, detail)
        factory = _default_factory(node_type, detail)
        if (type_name, field_name) in _FIELD_DEFAULTS:
            default = _FIELD_DEFAULTS[type_name, field_name]
            factory = lambda default=default: default  # noqa: E731
        namespace[field_name] = dataclasses.field(default_factory=factory)
    cls: Any = IdlMeta(name, (IdlStruct,), namespace)
    cls = dataclasses.dataclass(cls)
    cls.__module__ = f"{package}.msg"
    cls.__qualname__ = name
    cls._ros_type = type_name
    cls._ros_fields = tuple(fields)
    field_types = {fname: _rclpy_field_type(nt, det) for fname, (nt, det) in fields}
    cls.get_fields_and_field_types = classmethod(lambda _cls, _types=field_types: dict(_types))
    for const_name, const_type, value in constants:
        setattr(cls, const_name, bytes((value,)) if const_type == "byte" else value)
    _install_bulk_machines(cls, fields)
    _CLASSES[type_name] = cls
    return cls


def serialize(message: Any) -> bytes:
    """CDR (XCDR1, little endian, with the 4-byte encapsulation header) of a generated message."""
    return message.serialize(use_version_2=False)


def deserialize(data: bytes | memoryview, message_type: Any) -> Any:
    """Inverse of :func:`serialize`."""
    return message_type.deserialize(bytes(data))


__all__ = [
    "dds_type_name",
    "deserialize",
    "get_message",
    "is_message",
    "message_definition",
    "normalize_type_name",
    "ros_type_name",
    "serialize",
    "typestore",
]
