"""``Node`` of the DDS backend: the subset of ``rclpy.node.Node`` the project uses."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from wildfire_msgs_py.errors import ParameterError, ShutdownError
from wildfire_msgs_py.types import get_message
from wildfire_ros.dds.arguments import parse_ros_arguments
from wildfire_ros.dds.clock import ROSClock
from wildfire_ros.dds.context import Context, default_context
from wildfire_ros.dds.endpoints import Publisher, Subscription, Timer
from wildfire_ros.dds.log import Logger
from wildfire_ros.dds.names import expand_topic_name, validate_namespace, validate_node_name
from wildfire_ros.dds.parameters import (
    Parameter,
    ParameterType,
    SetParametersResult,
    check_range,
    coerce,
)
from wildfire_ros.dds.qos import QoSProfile, ReliabilityPolicy, as_profile

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence


class Node:
    """A ROS 2 node on the shared DDS participant.

    Supports publishers, subscriptions (also ``raw=True``), timers on the node clock,
    declared parameters with overrides from ``--ros-args``/parameter files/``parameter_overrides``,
    ``use_sim_time`` (the clock follows ``/clock``), ``__node``/``__ns`` and topic remapping.

    As in rclpy, ``cli_args`` are this node's own command line (``["--ros-args", "-r",
    "__ns:=/uav0", "-p", "aircraft:=0"]``), applied after the process's arguments (those of
    ``rclpy.init``), which ``use_global_arguments=False`` leaves out: several nodes of one
    process (composition) each get their own name, namespace and parameters.
    """

    def __init__(
        self,
        node_name: str,
        *,
        context: Context | None = None,
        namespace: str | None = None,
        cli_args: Sequence[str] | None = None,
        parameter_overrides: Sequence[Parameter] | None = None,
        use_global_arguments: bool = True,
        **_ignored: Any,
    ) -> None:
        self.context = context or default_context
        if not self.context.ok():
            raise ShutdownError("ROS is not initialized: call rclpy.init() before creating a Node")
        # rcl's order: the node's own arguments win over the process's.
        sources = [self.context.arguments] if use_global_arguments else []
        if cli_args:
            sources.append(parse_ros_arguments(cli_args))
        remaps = {
            src: dst for arguments in sources for src, dst in arguments.remap_for(node_name).items()
        }
        self._name = validate_node_name(remaps.pop("__node", node_name))
        self._namespace = validate_namespace(remaps.pop("__ns", namespace or "/"))
        self._topic_remaps = {
            expand_topic_name(src, self._name, self._namespace): expand_topic_name(
                dst, self._name, self._namespace
            )
            for src, dst in remaps.items()
        }
        fully_qualified = self.get_fully_qualified_name()
        self._overrides = {
            name: override
            for arguments in sources
            for name, override in arguments.parameters_for(fully_qualified).items()
        }
        self._explicit_overrides = {p.name: p.value for p in parameter_overrides or ()}
        self._parameters: dict[str, Parameter] = {}
        self._descriptors: dict[str, Any] = {}
        self._set_callbacks: list[Callable[[list[Parameter]], Any]] = []
        self._logger = Logger(self._logger_name())
        self.publishers: list[Publisher] = []
        self.subscriptions: list[Subscription] = []
        self.timers: list[Timer] = []
        self._clock = ROSClock()
        self._clock_subscription: Subscription | None = None
        self._destroyed = False
        self.context.register_node(self)
        self.declare_parameter("use_sim_time", False)
        self._apply_use_sim_time(bool(self.get_parameter("use_sim_time").value))

    # --- names, logger, clock -------------------------------------------------------------------

    def get_name(self) -> str:
        """The node name."""
        return self._name

    def get_namespace(self) -> str:
        """The absolute namespace."""
        return self._namespace

    def get_fully_qualified_name(self) -> str:
        """``/namespace/name``."""
        return self._namespace.rstrip("/") + "/" + self._name

    def _logger_name(self) -> str:
        return self.get_fully_qualified_name().lstrip("/").replace("/", ".")

    def get_logger(self) -> Logger:
        """The node logger."""
        return self._logger

    def get_clock(self) -> ROSClock:
        """The node's ROS clock (sim time when ``use_sim_time`` is true)."""
        return self._clock

    def resolve_topic_name(self, topic: str) -> str:
        """Absolute name after namespace expansion and remapping."""
        expanded = expand_topic_name(topic, self._name, self._namespace)
        return self._topic_remaps.get(expanded, expanded)

    # --- endpoints ------------------------------------------------------------------------------

    def create_publisher(
        self, msg_type: Any, topic: str, qos_profile: QoSProfile | int, **_ignored: Any
    ) -> Publisher:
        """A publisher on ``topic`` (relative names resolve against the namespace)."""
        publisher = Publisher(
            self.context, msg_type, self.resolve_topic_name(topic), as_profile(qos_profile)
        )
        self.publishers.append(publisher)
        return publisher

    def create_subscription(
        self,
        msg_type: Any,
        topic: str,
        callback: Callable[[Any], Any],
        qos_profile: QoSProfile | int,
        *,
        raw: bool = False,
        **_ignored: Any,
    ) -> Subscription:
        """A subscription; the executor calls ``callback(msg)`` (bytes when ``raw``)."""
        subscription = Subscription(
            self.context,
            msg_type,
            self.resolve_topic_name(topic),
            callback,
            as_profile(qos_profile),
            raw=raw,
        )
        self.subscriptions.append(subscription)
        return subscription

    def create_timer(
        self,
        timer_period_sec: float,
        callback: Callable[[], Any],
        clock: Any = None,
        **_ignored: Any,
    ) -> Timer:
        """A timer on the node clock (follows ``/clock`` in sim time)."""
        timer = Timer(callback, round(timer_period_sec * 1e9), clock or self._clock)
        self.timers.append(timer)
        return timer

    def destroy_publisher(self, publisher: Publisher) -> bool:
        """Delete one publisher."""
        return self._destroy(self.publishers, publisher)

    def destroy_subscription(self, subscription: Subscription) -> bool:
        """Delete one subscription."""
        return self._destroy(self.subscriptions, subscription)

    def destroy_timer(self, timer: Timer) -> bool:
        """Delete one timer."""
        return self._destroy(self.timers, timer)

    @staticmethod
    def _destroy(entities: list[Any], entity: Any) -> bool:
        if entity not in entities:
            return False
        entities.remove(entity)
        entity.destroy()
        return True

    def count_subscribers(self, topic: str) -> int:
        """Subscriptions of a topic in the whole graph."""
        return self.context.graph().count(self.resolve_topic_name(topic), "subscription")

    def count_publishers(self, topic: str) -> int:
        """Publishers of a topic in the whole graph."""
        return self.context.graph().count(self.resolve_topic_name(topic), "publication")

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        """Every topic in the graph with its types (``ros2 topic list -t``)."""
        return self.context.graph().topic_names_and_types()

    def destroy_node(self) -> None:
        """Delete every endpoint of this node."""
        if self._destroyed:
            return
        self._destroyed = True
        for entities in (self.timers, self.subscriptions, self.publishers):
            for entity in entities:
                entity.destroy()
            entities.clear()
        self._clock_subscription = None

    # --- parameters -----------------------------------------------------------------------------

    def declare_parameter(
        self, name: str, value: Any = None, descriptor: Any = None, ignore_override: bool = False
    ) -> Parameter:
        """Declare a parameter; an override (command line, file, constructor) wins."""
        if name in self._parameters:
            raise ParameterError(f"parameter {name!r} of node {self._name} is already declared")
        expected = ParameterType.from_parameter_value(value)
        source = f"node {self.get_fully_qualified_name()}"
        if not ignore_override and name in self._explicit_overrides:
            value = coerce(name, self._explicit_overrides[name], expected, source)
        elif not ignore_override and name in self._overrides:
            override = self._overrides[name]
            value = coerce(name, override.value, expected, override.source)
            source = override.source
        check_range(name, value, descriptor, source)
        parameter = Parameter(name, value=value)
        self._parameters[name] = parameter
        self._descriptors[name] = descriptor
        return parameter

    def declare_parameters(
        self, namespace: str, parameters: Sequence[tuple[Any, ...]], ignore_override: bool = False
    ) -> list[Parameter]:
        """Declare several ``(name, default[, descriptor])`` under ``namespace.``."""
        prefix = f"{namespace}." if namespace else ""
        return [
            self.declare_parameter(
                prefix + entry[0],
                entry[1] if len(entry) > 1 else None,
                entry[2] if len(entry) > 2 else None,
                ignore_override=ignore_override,
            )
            for entry in parameters
        ]

    def has_parameter(self, name: str) -> bool:
        """True once declared."""
        return name in self._parameters

    def get_parameter(self, name: str) -> Parameter:
        """A declared parameter (raises :class:`ParameterError` when undeclared)."""
        if name not in self._parameters:
            raise ParameterError(f"parameter {name!r} of node {self._name} is not declared")
        return self._parameters[name]

    def get_parameter_or(self, name: str, alternative_value: Parameter | None = None) -> Parameter:
        """The parameter, or ``alternative_value`` when undeclared."""
        return self._parameters.get(name, alternative_value)  # type: ignore[return-value]

    def get_parameters(self, names: Sequence[str]) -> list[Parameter]:
        """Several declared parameters."""
        return [self.get_parameter(name) for name in names]

    def add_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], Any]) -> None:
        """Veto or observe ``set_parameters`` (callback returns a SetParametersResult)."""
        self._set_callbacks.append(callback)

    def set_parameters(self, parameters: Sequence[Parameter]) -> list[SetParametersResult]:
        """Set declared parameters (type and range checked); one result per parameter."""
        results = []
        for parameter in parameters:
            try:
                current = self.get_parameter(parameter.name)
                value = coerce(parameter.name, parameter.value, current.type_, "set_parameters")
                check_range(
                    parameter.name, value, self._descriptors.get(parameter.name), "set_parameters"
                )
            except ParameterError as error:
                results.append(SetParametersResult(False, str(error)))
                continue
            new = Parameter(parameter.name, value=value)
            verdicts = [callback([new]) for callback in self._set_callbacks]
            refused = [v for v in verdicts if v is not None and not v.successful]
            if refused:
                results.append(SetParametersResult(False, refused[0].reason))
                continue
            self._parameters[parameter.name] = new
            if parameter.name == "use_sim_time":
                self._apply_use_sim_time(bool(value))
            results.append(SetParametersResult(True))
        return results

    # --- sim time -------------------------------------------------------------------------------

    def _apply_use_sim_time(self, enabled: bool) -> None:
        self._clock._set_ros_time_is_active(enabled)
        if enabled and self._clock_subscription is None:
            # rclpy's TimeSource subscribes to /clock best effort, depth 1.
            qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
            self._clock_subscription = self.create_subscription(
                get_message("rosgraph_msgs/msg/Clock"), "/clock", self._clock_callback, qos
            )
        elif not enabled and self._clock_subscription is not None:
            self.destroy_subscription(self._clock_subscription)
            self._clock_subscription = None

    def _clock_callback(self, msg: Any) -> None:
        self._clock._set_ros_time(msg.clock.sec * 1_000_000_000 + msg.clock.nanosec)


__all__ = ["Node"]
