"""``--ros-args`` parsing and parameter files, following rcl's rules.

Supported: ``-p/--param [node:]name:=value`` (value parsed as YAML, so ``3`` is an int, ``3.0`` a
float, ``true`` a bool, ``[1, 2]`` a list), ``--params-file FILE`` (``node: ros__parameters: ...``
with node keys being fully qualified names, ``/**`` or other ``*``/``**`` wildcards; nested
dictionaries become dotted names), ``-r/--remap [node:]from:=to`` (including ``__ns`` and
``__node``), ``--log-level [logger:=]LEVEL``; the logging/enclave flags ROS accepts are accepted
and ignored. A parameter file key without a leading ``/`` is taken as absolute, as rcl does:
``agent: ...`` matches ``/agent`` only, use ``/**/agent`` for a node in any namespace.
Parameter files are applied first, then ``-p`` options, each in command-line order.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from wildfire_msgs_py.errors import ParameterError

if TYPE_CHECKING:
    from collections.abc import Sequence

_IGNORED_FLAGS_WITH_VALUE = {"-e", "--enclave"}
_IGNORED_FLAGS = {
    "--enable-rosout-logs",
    "--disable-rosout-logs",
    "--enable-stdout-logs",
    "--disable-stdout-logs",
    "--enable-external-lib-logs",
    "--disable-external-lib-logs",
}
_NAME = re.compile(r"^[A-Za-z_~][A-Za-z0-9_./~]*$")
LOG_LEVELS = ("debug", "info", "warn", "error", "fatal")


@dataclass
class ParameterOverride:
    """One parameter value from the command line or a file."""

    node_pattern: str | None
    """Fully qualified node pattern (``/**``, ``/uav0/agent``) or None for every node."""
    name: str
    value: Any
    source: str
    """Where it came from, for error messages."""


@dataclass
class RosArguments:
    """Everything ``--ros-args`` said."""

    overrides: list[ParameterOverride] = field(default_factory=list)
    remaps: list[tuple[str | None, str, str]] = field(default_factory=list)
    log_level: str = "info"

    def parameters_for(self, fully_qualified_node: str) -> dict[str, ParameterOverride]:
        """Overrides that apply to one node; later ones win."""
        result: dict[str, ParameterOverride] = {}
        for override in self.overrides:
            if override.node_pattern is None or node_pattern_matches(
                override.node_pattern, fully_qualified_node
            ):
                result[override.name] = override
        return result

    def remap_for(self, node_name: str) -> dict[str, str]:
        """Remapping rules that apply to a node (by its base name)."""
        return {src: dst for node, src, dst in self.remaps if node in (None, node_name)}


def node_pattern_matches(pattern: str, fully_qualified_node: str) -> bool:
    """rcl wildcard match: ``*`` one name token, ``**`` any number of tokens."""
    if not pattern.startswith("/"):
        pattern = "/" + pattern
    regex = ""
    for token in re.split(r"(\*\*|\*)", pattern):
        if token == "**":
            regex += ".*"
        elif token == "*":
            regex += "[^/]*"
        else:
            regex += re.escape(token)
    # "/**" must also match "/node": let "/**/" and a trailing "/**" match nothing as well.
    regex = regex.replace("/.*/", "(/.*)?/").replace("/.*", "(/.*)?") if "**" in pattern else regex
    return re.fullmatch(regex, fully_qualified_node) is not None


def parse_value(text: str, where: str) -> Any:
    """A parameter value as YAML (``3`` int, ``3.0`` float, ``true`` bool, ``[1, 2]`` list)."""
    try:
        value = yaml.safe_load(text) if text.strip() else ""
    except yaml.YAMLError as error:
        raise ParameterError(
            f"{where}: value {text!r} is not valid YAML ({_first_line(error)})"
        ) from None
    if value is None:
        raise ParameterError(f"{where}: empty value; expected a number, bool, string or list")
    _check_value_type(value, where)
    return value


def _check_value_type(value: Any, where: str) -> None:
    if isinstance(value, bool | int | float | str):
        return
    if isinstance(value, list) and value:
        kinds = {bool if isinstance(v, bool) else type(v) for v in value}
        if kinds <= {int, float} or (len(kinds) == 1 and kinds <= {bool, int, float, str}):
            return
    if isinstance(value, list) and not value:
        return
    raise ParameterError(
        f"{where}: value {value!r} is not a ROS parameter type "
        "(expected bool, int, float, string or a list of one of these)"
    )


def _first_line(error: Exception) -> str:
    return str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__


def _split_assignment(text: str, flag: str) -> tuple[str | None, str, str]:
    """``[node:]name:=value`` -> (node, name, value)."""
    if ":=" not in text:
        raise ParameterError(f"--ros-args {flag} {text!r}: expected NAME:=VALUE")
    target, value = text.split(":=", 1)
    node = None
    if ":" in target:
        node, target = target.split(":", 1)
    if not target or not _NAME.match(target):
        raise ParameterError(f"--ros-args {flag} {text!r}: {target!r} is not a valid name")
    return node, target, value


def load_params_file(path: str | Path) -> list[ParameterOverride]:
    """Parameter overrides from a ``ros__parameters`` YAML file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise ParameterError(f"--params-file {path}: cannot read ({error.strerror})") from None
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ParameterError(
            f"--params-file {path}: malformed YAML ({_first_line(error)})"
        ) from None
    if not isinstance(document, dict):
        raise ParameterError(
            f"--params-file {path}: expected a mapping 'node_name: {{ros__parameters: {{...}}}}'"
        )
    overrides: list[ParameterOverride] = []
    for node_key, section in document.items():
        if not isinstance(section, dict) or not isinstance(section.get("ros__parameters"), dict):
            raise ParameterError(
                f"--params-file {path}: entry {node_key!r} has no 'ros__parameters' mapping"
            )
        pattern = str(node_key) if str(node_key).startswith("/") else "/" + str(node_key)
        for name, value in _flatten(section["ros__parameters"]):
            where = f"--params-file {path}: {node_key}.{name}"
            _check_value_type(value, where)
            overrides.append(ParameterOverride(pattern, name, value, where))
    return overrides


def _flatten(mapping: dict[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    items: list[tuple[str, Any]] = []
    for key, value in mapping.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            items.extend(_flatten(value, name + "."))
        else:
            items.append((name, value))
    return items


def ros_argument_sections(args: Sequence[str]) -> tuple[list[str], list[str]]:
    """Split a command line into (ROS arguments, the rest)."""
    ros: list[str] = []
    rest: list[str] = []
    inside = False
    for arg in args:
        if arg == "--ros-args":
            inside = True
        elif inside and arg == "--":
            inside = False
        elif inside:
            ros.append(arg)
        else:
            rest.append(arg)
    return ros, rest


def remove_ros_args(args: Sequence[str]) -> list[str]:
    """The command line without its ``--ros-args ... [--]`` sections (``rclpy.utilities``)."""
    return ros_argument_sections(args)[1]


def parse_ros_arguments(args: Sequence[str] | None) -> RosArguments:
    """Parse the ``--ros-args`` sections of a command line; raises :class:`ParameterError`."""
    ros, _ = ros_argument_sections(list(args or []))
    parsed = RosArguments()
    files: list[ParameterOverride] = []
    cli: list[ParameterOverride] = []
    i = 0

    def value_of(flag: str) -> str:
        if i + 1 >= len(ros):
            raise ParameterError(f"--ros-args {flag}: missing its argument")
        return ros[i + 1]

    while i < len(ros):
        flag = ros[i]
        if flag in ("-p", "--param"):
            node, name, text = _split_assignment(value_of(flag), flag)
            where = f"--ros-args {flag} {name}"
            cli.append(
                ParameterOverride(
                    None if node is None else f"/**/{node}", name, parse_value(text, where), where
                )
            )
            i += 2
        elif flag == "--params-file":
            files.extend(load_params_file(value_of(flag)))
            i += 2
        elif flag in ("-r", "--remap"):
            node, src, dst = _split_assignment(value_of(flag), flag)
            parsed.remaps.append((node, src, dst))
            i += 2
        elif flag == "--log-level":
            text = value_of(flag)
            level = text.split(":=", 1)[-1].lower()
            if level not in LOG_LEVELS:
                raise ParameterError(
                    f"--ros-args --log-level {text!r}: expected one of {', '.join(LOG_LEVELS)}"
                )
            parsed.log_level = level
            i += 2
        elif flag in _IGNORED_FLAGS_WITH_VALUE:
            value_of(flag)
            i += 2
        elif flag in _IGNORED_FLAGS:
            i += 1
        else:
            raise ParameterError(
                f"--ros-args: unknown option {flag!r} (expected -p NAME:=VALUE, "
                "--params-file FILE, -r FROM:=TO or --log-level LEVEL)"
            )
    parsed.overrides = files + cli
    return parsed


__all__ = [
    "LOG_LEVELS",
    "ParameterOverride",
    "RosArguments",
    "load_params_file",
    "node_pattern_matches",
    "parse_ros_arguments",
    "parse_value",
    "remove_ros_args",
]
