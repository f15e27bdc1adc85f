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
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from wildfire_msgs_py.contract import QosSpec, TopicSpec
from wildfire_msgs_py.errors import ParameterError, WildfireRosError

EXIT_USER_ERROR = 2


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
        from wildfire_msgs_py.runtime import FloatingPointRange, IntegerRange, ParameterDescriptor

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
    overrides = getattr(node, "_overrides", None)  # DDS backend: name -> ParameterOverride
    if overrides is None:
        return  # rclpy keeps no record of where an override came from: nothing to check
    for name, override in overrides.items():
        if name in known or override.node_pattern in ("/**", "**"):
            continue
        raise ParameterError(
            f"{override.source}: unknown parameter {name!r} for node "
            f"{node.get_fully_qualified_name()} (known: {', '.join(sorted(known))})"
        )
    explicit = getattr(node, "_explicit_overrides", {})
    for name in explicit:
        if name not in known:
            raise ParameterError(f"unknown parameter {name!r} for node {node.get_name()}")


def contract_publisher(node: Any, spec: TopicSpec, aircraft: int | None = None) -> Any:
    """Publisher of ``spec`` (aircraft ``aircraft``'s instance for per-aircraft topics)."""
    from wildfire_msgs_py.runtime import get_message

    return node.create_publisher(get_message(spec.type), spec.resolve(aircraft), spec.qos.profile())


def contract_subscription(
    node: Any,
    spec: TopicSpec,
    callback: Callable[[Any], None],
    aircraft: int | None = None,
    qos: QosSpec | None = None,
) -> Any:
    """Subscription to ``spec`` with its QoS, or ``qos`` where a reader needs a deeper history."""
    from wildfire_msgs_py.runtime import get_message

    return node.create_subscription(
        get_message(spec.type), spec.resolve(aircraft), callback, (qos or spec.qos).profile()
    )


def _raise_keyboard_interrupt(_signum: int, _frame: Any) -> None:
    raise KeyboardInterrupt


def interrupt_on_stop_signals() -> None:
    """Turn SIGINT and SIGTERM into ``KeyboardInterrupt``: ``kill``, ``timeout``, a launcher
    or ``docker stop`` then end a node, a recording or a training run the way Ctrl-C does.

    SIGINT is set explicitly too: a process started in the background by a non-interactive
    shell inherits SIGINT *ignored*, and Python keeps it so. Such a recorder would never see
    the launcher's SIGINT (rclpy, likewise, installs its own handlers).
    """
    signal.signal(signal.SIGINT, _raise_keyboard_interrupt)
    signal.signal(signal.SIGTERM, _raise_keyboard_interrupt)


def run_node(
    build: Callable[[], Any],
    program: str,
    args: Sequence[str] | None = None,
    user_errors: tuple[type[BaseException], ...] = (),
) -> int:
    """Init the runtime, ``build()`` the node, spin it; return the exit status.

    SIGINT and SIGTERM end the node cleanly (:func:`interrupt_on_stop_signals`).
    """
    from wildfire_msgs_py.runtime import PARAMETER_ERRORS, ExternalShutdownException, rclpy

    errors = (*PARAMETER_ERRORS, WildfireRosError, *user_errors)
    # rclpy reads sys.argv when args is None; the DDS backend needs them given.
    args = list(sys.argv if args is None else args)
    interrupt_on_stop_signals()
    try:
        rclpy.init(args=args)
    except errors as error:
        print(f"{program}: error: {error}", file=sys.stderr)
        return EXIT_USER_ERROR
    node = None
    status = 0
    try:
        node = build()
        rclpy.spin(node)
    except errors as error:
        print(f"{program}: error: {error}", file=sys.stderr)
        status = EXIT_USER_ERROR
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        # A second signal during clean-up must not turn into a traceback.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return status


__all__ = [
    "EXIT_USER_ERROR",
    "ParamSpec",
    "contract_publisher",
    "contract_subscription",
    "declare_parameters",
    "interrupt_on_stop_signals",
    "reject_unknown_parameters",
    "run_node",
]
