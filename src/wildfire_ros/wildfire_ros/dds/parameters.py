"""Parameters with rclpy's ``Parameter`` interface and descriptor range checks."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Any

from wildfire_msgs_py.errors import ParameterError


class ParameterType(IntEnum):
    """As ``rclpy.parameter.Parameter.Type`` (values of ``rcl_interfaces/msg/ParameterType``)."""

    NOT_SET = 0
    BOOL = 1
    INTEGER = 2
    DOUBLE = 3
    STRING = 4
    BYTE_ARRAY = 5
    BOOL_ARRAY = 6
    INTEGER_ARRAY = 7
    DOUBLE_ARRAY = 8
    STRING_ARRAY = 9

    @classmethod
    def from_parameter_value(cls, value: Any) -> ParameterType:
        """The type of a Python value; raises :class:`ParameterError` for unsupported ones."""
        if value is None:
            return cls.NOT_SET
        if isinstance(value, bool):
            return cls.BOOL
        if isinstance(value, int):
            return cls.INTEGER
        if isinstance(value, float):
            return cls.DOUBLE
        if isinstance(value, str):
            return cls.STRING
        if isinstance(value, bytes):
            return cls.BYTE_ARRAY
        if isinstance(value, list | tuple):
            if all(isinstance(v, bool) for v in value):
                return cls.BOOL_ARRAY if value else cls.STRING_ARRAY
            if all(isinstance(v, int) and not isinstance(v, bool) for v in value):
                return cls.INTEGER_ARRAY
            if all(isinstance(v, int | float) and not isinstance(v, bool) for v in value):
                return cls.DOUBLE_ARRAY
            if all(isinstance(v, str) for v in value):
                return cls.STRING_ARRAY
        raise ParameterError(f"value {value!r} is not a valid ROS parameter value")


class Parameter:
    """A named, typed value (``rclpy.parameter.Parameter``)."""

    Type = ParameterType

    def __init__(self, name: str, type_: ParameterType | None = None, value: Any = None) -> None:
        if type_ is None:
            type_ = ParameterType.from_parameter_value(value)
        self.name = name
        self.type_ = ParameterType(type_)
        self.value = list(value) if isinstance(value, tuple) else value

    def __repr__(self) -> str:
        return f"Parameter(name={self.name!r}, type={self.type_.name}, value={self.value!r})"


@dataclass
class SetParametersResult:
    """As ``rcl_interfaces/msg/SetParametersResult``."""

    successful: bool
    reason: str = ""


def coerce(name: str, value: Any, expected: ParameterType, source: str) -> Any:
    """``value`` converted to the declared type, int->float allowed; else a clear error."""
    actual = ParameterType.from_parameter_value(value)
    if expected in (ParameterType.NOT_SET, actual):
        return value
    if expected == ParameterType.DOUBLE and actual == ParameterType.INTEGER:
        return float(value)
    if expected == ParameterType.DOUBLE_ARRAY and actual == ParameterType.INTEGER_ARRAY:
        return [float(v) for v in value]
    if not value and expected.name.endswith("_ARRAY") and isinstance(value, list):
        return value
    raise ParameterError(
        f"{source}: parameter {name!r} got {value!r} ({actual.name.lower()}), "
        f"expected {expected.name.lower().replace('_', ' ')}"
    )


def check_range(name: str, value: Any, descriptor: Any, source: str) -> None:
    """Enforce a descriptor's ``floating_point_range``/``integer_range`` like rclpy."""
    if descriptor is None or value is None:
        return
    for ranges in (
        getattr(descriptor, "floating_point_range", None),
        getattr(descriptor, "integer_range", None),
    ):
        if not ranges or isinstance(value, bool) or not isinstance(value, int | float):
            continue
        bounds = ranges[0]
        low, high = bounds.from_value, bounds.to_value
        if not low <= value <= high:
            raise ParameterError(
                f"{source}: parameter {name!r} = {value!r} is out of range, expected {low}..{high}"
            )


__all__ = ["Parameter", "ParameterType", "SetParametersResult", "check_range", "coerce"]
