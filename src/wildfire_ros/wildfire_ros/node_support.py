"""What every node of the system shares: checked parameters and a ``main`` that never dumps
a traceback for a user mistake.

* :class:`ParamSpec` / :func:`declare_parameters` declare parameters up front with a
  description and, for numbers, an inclusive range (enforced by the runtime: an out-of-range
  value raises one of ``runtime.PARAMETER_ERRORS``); choices are checked here.
* :func:`reject_unknown_parameters` refuses overrides (``-p``, parameter files addressed to
  this node) that name no declared parameter, so a typo is an error rather than ignored.
  Entries of a ``/**`` section are shared by every node and are not checked.
* :func:`contract_publisher` / :func:`contract_subscription` create an endpoint of a contract
  topic with its type, resolved name and QoS, so nodes never restate them.
* :func:`run_node` is the body of every ``main(args=None)``: init, build, spin until
  Ctrl-C/SIGTERM/shutdown, destroy, shut down. A start-up error of the kinds given is printed
  as one line ``<node>: error: ...`` and the process exits with status 2.
* :func:`run_composed` does the same for several nodes of one class in one process, on one
  executor (ROS 2 composition): each ``--node`` section of the command line is one node's own
  ``--ros-args`` (``Node(cli_args=..., use_global_arguments=False)``, on both backends).
"""

from __future__ import annotations

import functools
import signal
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from wildfire_msgs_py.contract import QosSpec, TopicSpec
from wildfire_msgs_py.errors import ParameterError, WildfireRosError
from wildfire_msgs_py.input_guard import InputGuard
from wildfire_msgs_py.stop_signals import interrupt_on_stop_signals, stopped

EXIT_USER_ERROR = 2
NODE_SECTION = "--node"
"""Starts one node's own arguments on a composed process's command line."""

#: The command line ``run_node`` initialized the runtime with (``None``: ``sys.argv``).
_init_args: list[str] | None = None
#: The own arguments of the composed node being built (``None``: not composed).
_node_args: list[str] | None = None


@dataclass(frozen=True)
class ParamSpec:
    """One declared parameter."""

    name: str
    default: Any
    description: str
    low: float | None = None
    """Inclusive lower bound (numbers only)."""
    high: float | None = None
    """Inclusive upper bound (numbers only)."""
    choices: tuple[str, ...] | None = None
    """Allowed values of a string parameter."""

    def descriptor(self) -> Any:
        from wildfire_ros.runtime import FloatingPointRange, IntegerRange, ParameterDescriptor

        descriptor = ParameterDescriptor(name=self.name, description=self.description)
        if self.low is not None and self.high is not None:
            if isinstance(self.default, bool):
                pass
            elif isinstance(self.default, int):
                descriptor.integer_range = [
                    IntegerRange(from_value=int(self.low), to_value=int(self.high), step=0)
                ]
            elif isinstance(self.default, float):
                descriptor.floating_point_range = [
                    FloatingPointRange(
                        from_value=float(self.low), to_value=float(self.high), step=0.0
                    )
                ]
        if self.choices:
            descriptor.additional_constraints = "one of: " + ", ".join(self.choices)
        return descriptor


def declare_parameters(node: Any, specs: Sequence[ParamSpec]) -> dict[str, Any]:
    """Declare ``specs`` on ``node`` and return their values by name (checked)."""
    values = {}
    for spec in specs:
        _accept_integer_for_double(node, spec)
        value = node.declare_parameter(spec.name, spec.default, spec.descriptor()).value
        if spec.choices is not None and value not in spec.choices:
            raise ParameterError(
                f"node {node.get_fully_qualified_name()}: parameter {spec.name!r} = {value!r}, "
                f"expected one of {', '.join(spec.choices)}"
            )
        values[spec.name] = value
    reject_unknown_parameters(node, specs)
    return values


def reject_unknown_parameters(node: Any, specs: Sequence[ParamSpec]) -> None:
    """Raise :class:`ParameterError` for an override addressed to ``node`` it does not declare."""
    known = {spec.name for spec in specs} | {"use_sim_time"}
    sourced = _command_line_overrides(node)
    for name, override in sourced.items():
        if name in known or override.node_pattern in ("/**", "**"):
            continue
        raise ParameterError(
            f"{override.source}: unknown parameter {name!r} for node "
            f"{node.get_fully_qualified_name()} (known: {', '.join(sorted(known))})"
        )
    for name in _constructor_overrides(node, sourced):
        if name not in known:
            raise ParameterError(f"unknown parameter {name!r} for node {node.get_name()}")


def _command_line_overrides(node: Any) -> dict[str, Any]:
    """Overrides from ``-p`` and parameter files addressed to ``node``, with their source.

    The DDS backend keeps them on the node. rclpy merges every source into one dict with no
    origin, so the command line rclpy was initialized with is parsed again by the same parser
    (:func:`wildfire_ros.dds.arguments.parse_ros_arguments`).
    """
    overrides = getattr(node, "_overrides", None)
    if overrides is not None:
        return dict(overrides)
    from wildfire_ros.dds.arguments import parse_ros_arguments

    args = _node_args if _node_args is not None else sys.argv if _init_args is None else _init_args
    return parse_ros_arguments(args).parameters_for(node.get_fully_qualified_name())


def _constructor_overrides(node: Any, sourced: dict[str, Any]) -> set[str]:
    """Names given as ``Node(..., parameter_overrides=...)``."""
    explicit = getattr(node, "_explicit_overrides", None)  # DDS backend
    if explicit is not None:
        return set(explicit)
    return set(getattr(node, "_parameter_overrides", {})) - set(sourced)


def _accept_integer_for_double(node: Any, spec: ParamSpec) -> None:
    """Let ``-p gain:=1`` set a double parameter, as the DDS backend does.

    rclpy refuses an INTEGER override for a DOUBLE parameter; its overrides live in
    ``Node._parameter_overrides`` (rclpy 7.1), where the value is widened before declaring.
    """
    overrides = getattr(node, "_parameter_overrides", None)
    if not isinstance(spec.default, float) or not overrides or spec.name not in overrides:
        return
    value = overrides[spec.name].value
    if isinstance(value, int) and not isinstance(value, bool):
        from wildfire_ros.runtime import Parameter

        overrides[spec.name] = Parameter(spec.name, value=float(value))


def contract_publisher(node: Any, spec: TopicSpec, aircraft: int | None = None) -> Any:
    """Publisher of ``spec`` (aircraft ``aircraft``'s instance for per-aircraft topics)."""
    from wildfire_ros.runtime import get_message, qos_profile

    return node.create_publisher(
        get_message(spec.type), spec.resolve(aircraft), qos_profile(spec.qos)
    )


def contract_subscription(
    node: Any,
    spec: TopicSpec,
    callback: Callable[[Any], None],
    aircraft: int | None = None,
    qos: QosSpec | None = None,
    guard: InputGuard | None = None,
) -> Any:
    """Subscription to ``spec`` with its QoS, or ``qos`` where a reader needs a deeper history.

    With a ``guard``, a message the callback rejects (or cannot decode) is dropped and counted
    instead of raising out of the executor: any participant may publish anything.
    """
    from wildfire_ros.runtime import get_message, qos_profile

    topic = spec.resolve(aircraft)
    if guard is not None:
        callback = guard.guarded(topic, callback)
    return node.create_subscription(
        get_message(spec.type), topic, callback, qos_profile(qos or spec.qos)
    )


def run_node(
    build: Callable[[], Any],
    program: str,
    args: Sequence[str] | None = None,
    user_errors: tuple[type[BaseException], ...] = (),
) -> int:
    """Init the runtime, ``build()`` the node, spin it; return the exit status.

    SIGINT and SIGTERM end the node cleanly (:func:`interrupt_on_stop_signals`).
    """
    args = list(sys.argv if args is None else args)
    return _run_nodes([build], program, args, [args], user_errors)


def split_node_sections(args: Sequence[str]) -> tuple[list[str], list[list[str]]]:
    """A composed command line: (the process's own words, each ``--node`` section's)."""
    words = list(args)
    starts = [i for i, word in enumerate(words) if word == NODE_SECTION]
    if not starts:
        return words, []
    ends = [*starts[1:], len(words)]
    return words[: starts[0]], [words[a + 1 : b] for a, b in zip(starts, ends, strict=True)]


def composed_node(build: Callable[..., Any], cli_args: Sequence[str]) -> Any:
    """``build(cli_args=..., use_global_arguments=False)``: a node with its own arguments only."""
    global _node_args
    _node_args = list(cli_args)
    try:
        return build(cli_args=list(cli_args), use_global_arguments=False)
    finally:
        _node_args = None


def run_composed(
    build: Callable[..., Any],
    program: str,
    args: Sequence[str] | None = None,
    user_errors: tuple[type[BaseException], ...] = (),
) -> int:
    """:func:`run_node` for the nodes of the ``--node`` sections of ``args`` (see
    :func:`split_node_sections`), all built by ``build`` and spun on one executor.

    The words before the first ``--node`` initialize the runtime (``--log-level``, ...);
    parameters and remappings there would reach no node, so they are refused.
    """
    from wildfire_ros.dds.arguments import parse_ros_arguments

    own, sections = split_node_sections(sys.argv if args is None else args)
    try:
        process = parse_ros_arguments(own)
        if process.overrides or process.remaps:
            raise ParameterError(
                f"--ros-args before the first {NODE_SECTION}: parameters and remappings go in "
                "a node's own section"
            )
        if not sections:
            raise ParameterError(f"expected one {NODE_SECTION} --ros-args ... section per node")
    except ParameterError as error:
        print(f"{program}: error: {_first_line(error)}", file=sys.stderr)
        return EXIT_USER_ERROR
    builds = [functools.partial(composed_node, build, section) for section in sections]
    return _run_nodes(builds, program, own, sections, user_errors)


def _run_nodes(
    builds: Sequence[Callable[[], Any]],
    program: str,
    args: list[str],
    node_args: Sequence[Sequence[str]],
    user_errors: tuple[type[BaseException], ...],
) -> int:
    """Init the runtime with ``args``, build every node, spin them on one executor.

    ``node_args`` are the command lines the nodes read (checked first, for one-line errors).
    """
    from wildfire_ros.dds.arguments import parse_ros_arguments
    from wildfire_ros.runtime import (
        INIT_ERRORS,
        PARAMETER_ERRORS,
        ExternalShutdownException,
        make_executor,
        rclpy,
        spin,
    )

    global _init_args
    errors: tuple[type[BaseException], ...] = (*PARAMETER_ERRORS, WildfireRosError, *user_errors)
    # rclpy reads sys.argv when args is None; the DDS backend needs them given.
    _init_args = args
    interrupt_on_stop_signals()
    try:
        # Our parser first: a missing or malformed parameter file gets one line naming it on
        # both backends (rcl's own message is a multi-line parser trace).
        for words in node_args:
            parse_ros_arguments(words)
        rclpy.init(args=args)
    except (*errors, *INIT_ERRORS) as error:
        print(f"{program}: error: {_first_line(error)}", file=sys.stderr)
        return EXIT_USER_ERROR
    nodes: list[Any] = []
    status = 0
    executor = None
    try:
        for build in builds:
            nodes.append(build())
        executor = make_executor()
        for node in nodes:
            executor.add_node(node)
        spin(executor)
    except errors as error:
        print(f"{program}: error: {_first_line(error)}", file=sys.stderr)
        status = EXIT_USER_ERROR
    except ExternalShutdownException:
        pass
    except (KeyboardInterrupt, SystemError) as error:
        if not stopped(error):
            raise
    finally:
        # A second signal during clean-up must not turn into a traceback.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        if executor is not None:
            executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return status


def _first_line(error: BaseException) -> str:
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__


__all__ = [
    "EXIT_USER_ERROR",
    "NODE_SECTION",
    "ParamSpec",
    "composed_node",
    "contract_publisher",
    "contract_subscription",
    "declare_parameters",
    "reject_unknown_parameters",
    "run_composed",
    "run_node",
    "split_node_sections",
]
