"""Generic message <-> plain data, for ``topic echo``/``topic pub`` on either backend.

Works on any message class that offers ``get_fields_and_field_types()`` (rclpy's rosidl
classes and the DDS backend's generated classes) and on rosbags dataclasses.
"""

from __future__ import annotations

import array
import re
from typing import Any

import numpy as np
import yaml

from wildfire_msgs_py.errors import MessageFieldError

#: Sequences longer than this are cut in ``message_to_yaml`` (as ``ros2 topic echo``).
DEFAULT_TRUNCATE_LENGTH = 128
_INTEGER_TYPES = {"int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "char"}
_FLOAT_TYPES = {"float", "double", "float32", "float64"}


def field_types(msg_or_class: Any) -> dict[str, str]:
    """Field name -> type string (rclpy's spelling); rosbags dataclasses give ``""``."""
    getter = getattr(msg_or_class, "get_fields_and_field_types", None)
    if getter is not None:
        return dict(getter())
    fields = getattr(msg_or_class, "__dataclass_fields__", None)
    if fields is not None:
        return {name: "" for name in fields if name != "__msgtype__"}
    raise MessageFieldError(f"{type(msg_or_class).__name__} is not a ROS message")


def is_message(value: Any) -> bool:
    """True for a message object of any supported family."""
    return hasattr(value, "get_fields_and_field_types") or (
        hasattr(value, "__dataclass_fields__") and hasattr(value, "__msgtype__")
    )


def message_to_dict(
    msg: Any, truncate_length: int | None = DEFAULT_TRUNCATE_LENGTH
) -> dict[str, Any]:
    """Nested plain dict; sequences longer than ``truncate_length`` end with ``'...'``."""
    return {name: _to_plain(getattr(msg, name), truncate_length) for name in field_types(msg)}


def _to_plain(value: Any, truncate_length: int | None) -> Any:
    if is_message(value):
        return message_to_dict(value, truncate_length)
    if isinstance(value, array.array | np.ndarray | list | tuple):
        items = list(value[:truncate_length] if truncate_length is not None else value)
        plain = [_to_plain(item, truncate_length) for item in items]
        if truncate_length is not None and len(value) > truncate_length:
            plain.append("...")
        return plain
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, bytes):
        return repr(value)
    return value


def message_to_yaml(msg: Any, truncate_length: int | None = DEFAULT_TRUNCATE_LENGTH) -> str:
    """YAML text like ``ros2 topic echo`` prints (without the ``---`` separator)."""
    return yaml.safe_dump(
        message_to_dict(msg, truncate_length),
        sort_keys=False,
        default_flow_style=False,
        width=1 << 30,
        allow_unicode=True,
    )


def _element_type(type_string: str) -> str:
    """Element type: ``sequence<geometry_msgs/Point, 3>`` -> ``geometry_msgs/Point``."""
    inner = re.sub(r"^sequence<(.*?)(,\s*\d+)?>$", r"\1", type_string)
    inner = re.sub(r"\[\d*\]$", "", inner)
    return re.sub(r"<=\d+$", "", inner)


def _is_sequence_type(type_string: str) -> bool:
    return type_string.startswith("sequence<") or type_string.endswith("]")


def set_message_fields(msg: Any, values: Any, path: str = "") -> Any:
    """Set fields of ``msg`` from a nested dict (as ``rosidl_runtime_py.set_message_fields``)."""
    from wildfire_ros.runtime import get_message

    if values is None:
        return msg
    if not isinstance(values, dict):
        raise MessageFieldError(
            f"{path or 'message'}: expected a mapping of field names, got {values!r}"
        )
    types = field_types(msg)
    for name, value in values.items():
        where = f"{path}{name}"
        if name not in types:
            raise MessageFieldError(
                f"field {where!r} does not exist; expected one of: {', '.join(types)}"
            )
        type_string = types[name]
        element = _element_type(type_string)
        current = getattr(msg, name)
        if _is_sequence_type(type_string):
            if not isinstance(value, list):
                raise MessageFieldError(f"field {where!r}: expected a list, got {value!r}")
            if "/" in element:
                element_class = get_message(element)
                value = [
                    set_message_fields(element_class(), item, f"{where}[{i}].")
                    for i, item in enumerate(value)
                ]
            else:
                value = [
                    _convert_scalar(item, element, f"{where}[{i}]") for i, item in enumerate(value)
                ]
            setattr(msg, name, value)
        elif is_message(current):
            set_message_fields(current, value, f"{where}.")
        else:
            setattr(msg, name, _convert_scalar(value, element, where))
    return msg


def _convert_scalar(value: Any, type_string: str, where: str) -> Any:
    try:
        if type_string == "boolean" or type_string == "bool":
            if not isinstance(value, bool):
                raise TypeError
            return value
        if type_string in _INTEGER_TYPES:
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError
            return value
        if type_string in _FLOAT_TYPES:
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise TypeError
            return float(value)
        if type_string in ("octet", "byte"):
            if isinstance(value, int) and 0 <= value <= 255:
                return bytes((value,))
            raise TypeError
        if type_string.startswith("string") or type_string.startswith("wstring"):
            return value if isinstance(value, str) else str(value)
    except TypeError:
        raise MessageFieldError(f"field {where!r}: expected {type_string}, got {value!r}") from None
    return value


__all__ = [
    "DEFAULT_TRUNCATE_LENGTH",
    "field_types",
    "is_message",
    "message_to_dict",
    "message_to_yaml",
    "set_message_fields",
]
