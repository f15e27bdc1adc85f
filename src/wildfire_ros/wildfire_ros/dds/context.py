"""The process-wide DDS context: ``rclpy.init``/``shutdown`` state and the one participant.

Like rmw_cyclonedds_cpp in Jazzy, every node of a process shares one DDS participant (one
participant index on the loopback discovery ports, one set of DDS threads).
"""

from __future__ import annotations

import contextlib
import threading
import weakref
from typing import TYPE_CHECKING, Any

from cyclonedds.core import DDSException, GuardCondition
from cyclonedds.domain import DomainParticipant
from cyclonedds.topic import Topic

from wildfire_msgs_py.errors import ShutdownError, TopicNameError
from wildfire_ros.dds.arguments import RosArguments, parse_ros_arguments
from wildfire_ros.dds.config import ros_domain_id
from wildfire_ros.dds.log import set_global_level
from wildfire_ros.network_defaults import apply_local_network_defaults

if TYPE_CHECKING:
    from collections.abc import Sequence


class ExternalShutdownException(Exception):
    """Raised from spinning when the context was shut down elsewhere (as in rclpy)."""


class Context:
    """Initialization state, parsed ``--ros-args`` and the shared participant."""

    def __init__(self) -> None:
        self._lock = threading.RLock()
        self._ok = False
        self.arguments = RosArguments()
        self.domain_id = 0
        self._participant: DomainParticipant | None = None
        self._topics: dict[str, tuple[Topic[Any], Any]] = {}
        self._nodes: weakref.WeakSet[Any] = weakref.WeakSet()
        self._wake_guards: weakref.WeakSet[GuardCondition] = weakref.WeakSet()
        self._graph: Any = None

    def init(self, args: Sequence[str] | None = None, domain_id: int | None = None) -> None:
        """Parse ROS arguments and create the participant (``rclpy.init``)."""
        with self._lock:
            if self._ok:
                raise RuntimeError("Context.init() must only be called once")
            arguments = parse_ros_arguments(args)
            set_global_level(arguments.log_level)
            apply_local_network_defaults()
            self.domain_id = ros_domain_id() if domain_id is None else domain_id
            self.arguments = arguments
            self._participant = DomainParticipant(self.domain_id)
            self._ok = True

    def ok(self) -> bool:
        """True between ``init`` and ``shutdown``."""
        return self._ok

    @property
    def participant(self) -> DomainParticipant:
        """The DDS participant (raises when not initialized)."""
        if not self._ok or self._participant is None:
            raise ShutdownError("ROS is not initialized: call rclpy.init() first")
        return self._participant

    def topic(self, name: str, message_type: Any) -> Topic[Any]:
        """The DDS topic ``rt/<name>`` for a ROS topic name, created once per type."""
        with self._lock:
            known = self._topics.get(name)
            if known is not None:
                if known[1] is not message_type:
                    raise TopicNameError(
                        f"topic {name!r} is already used with type {known[1]._ros_type}, "
                        f"not {message_type._ros_type}"
                    )
                return known[0]
            topic = Topic(self.participant, "rt" + name, message_type)
            self._topics[name] = (topic, message_type)
            return topic

    def register_node(self, node: Any) -> None:
        """Remember a node so shutdown can destroy it."""
        self._nodes.add(node)

    def register_wake_guard(self, guard: GuardCondition) -> None:
        """A guard condition to trigger when the context shuts down (executor wake-up)."""
        self._wake_guards.add(guard)

    def graph(self) -> Any:
        """The lazily created graph monitor (builtin-topic readers)."""
        with self._lock:
            if self._graph is None:
                from wildfire_ros.dds.graph import GraphMonitor

                self._graph = GraphMonitor(self.participant)
            return self._graph

    def shutdown(self) -> None:
        """Destroy every node and the participant (``rclpy.shutdown``)."""
        with self._lock:
            if not self._ok:
                raise RuntimeError("Context must be initialized before it can be shutdown")
            self._ok = False
            for guard in list(self._wake_guards):
                with contextlib.suppress(DDSException):
                    guard.set(True)
            for node in list(self._nodes):
                node.destroy_node()
            self._topics.clear()
            if self._graph is not None:
                self._graph.close()
                self._graph = None
            participant, self._participant = self._participant, None
            if participant is not None:
                participant.__del__()

    def try_shutdown(self) -> None:
        """Shut down unless already shut down."""
        with self._lock:
            if self._ok:
                self.shutdown()


default_context = Context()


__all__ = ["Context", "ExternalShutdownException", "default_context"]
