"""``SingleThreadedExecutor``: runs timer and subscription callbacks of several nodes.

Each ``spin_once`` runs at most one callback (as rclpy): a due timer first, else the next
subscription with a pending message in round-robin order, else it blocks on a Cyclone DDS
wait set (one read condition per subscription plus a guard condition for shutdown) until a
message arrives, a wall-clock timer falls due or the timeout ends. Waits are cut into slices
of at most 100 ms so that Ctrl-C (a Python signal handler) is never delayed longer than that.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from cyclonedds.core import DDSException, GuardCondition, WaitSet

from wildfire_ros.dds.context import Context, ExternalShutdownException, default_context

if TYPE_CHECKING:
    from wildfire_ros.dds.endpoints import Subscription, Timer
    from wildfire_ros.dds.node import Node

_SLICE_NS = 100_000_000


class SingleThreadedExecutor:
    """As ``rclpy.executors.SingleThreadedExecutor``."""

    def __init__(self, *, context: Context | None = None) -> None:
        self.context = context or default_context
        self._nodes: list[Node] = []
        self._is_shutdown = False
        self._next_subscription = 0
        self._wait_set: WaitSet | None = None
        self._guard: GuardCondition | None = None
        self._attached: tuple[int, ...] = ()

    def add_node(self, node: Node) -> bool:
        """Add a node; False when it was already added."""
        if node in self._nodes:
            return False
        self._nodes.append(node)
        return True

    def remove_node(self, node: Node) -> None:
        """Stop running a node's callbacks."""
        if node in self._nodes:
            self._nodes.remove(node)

    def get_nodes(self) -> list[Node]:
        """The nodes added."""
        return list(self._nodes)

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        """Stop spinning and forget every node."""
        self._is_shutdown = True
        self._nodes.clear()
        self._set_guard(True)
        self._wait_set = None
        self._attached = ()
        return True

    def spin(self) -> None:
        """Run callbacks until the context or this executor shuts down."""
        while self.context.ok() and not self._is_shutdown:
            self.spin_once()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        """Run one ready callback, waiting up to ``timeout_sec`` (None: forever) for one."""
        deadline = None if timeout_sec is None else time.monotonic_ns() + int(timeout_sec * 1e9)
        while True:
            if not self.context.ok():
                raise ExternalShutdownException("context has been shut down")
            if self._is_shutdown:
                return
            if self._run_one():
                return
            wait_ns = _SLICE_NS
            now = time.monotonic_ns()
            if deadline is not None:
                if now >= deadline:
                    return
                wait_ns = min(wait_ns, deadline - now)
            for timer in self._timers():
                if not timer.follows_sim_time:
                    until = timer.time_until_next_call()
                    if until is not None:
                        wait_ns = min(wait_ns, max(0, until))
            if wait_ns > 0:
                self._wait(wait_ns)

    def spin_until_future_complete(self, future: Any, timeout_sec: float | None = None) -> None:
        """Spin until ``future.done()`` (anything with ``done()``) or the timeout."""
        end = None if timeout_sec is None else time.monotonic() + timeout_sec
        while self.context.ok() and not future.done():
            remaining = None if end is None else end - time.monotonic()
            if remaining is not None and remaining <= 0:
                return
            self.spin_once(timeout_sec=remaining if remaining is not None else 0.1)

    # --- internals ------------------------------------------------------------------------------

    def _timers(self) -> list[Timer]:
        return [timer for node in self._nodes for timer in node.timers]

    def _subscriptions(self) -> list[Subscription]:
        return [sub for node in self._nodes for sub in node.subscriptions]

    def _run_one(self) -> bool:
        ready = [timer for timer in self._timers() if timer.is_ready()]
        if ready:
            timer = min(ready, key=lambda t: t._next_call_ns)
            timer.call()
            return True
        subscriptions = self._subscriptions()
        count = len(subscriptions)
        for offset in range(count):
            index = (self._next_subscription + offset) % count
            subscription = subscriptions[index]
            message = subscription.take()
            if message is not None:
                self._next_subscription = index + 1
                subscription.callback(message)
                return True
        return False

    def _wait(self, timeout_ns: int) -> None:
        subscriptions = self._subscriptions()
        key = tuple(id(sub.condition) for sub in subscriptions)
        if self._wait_set is None or key != self._attached:
            participant = self.context.participant
            self._wait_set = WaitSet(participant)
            self._guard = GuardCondition(participant)
            self.context.register_wake_guard(self._guard)
            self._wait_set.attach(self._guard)
            for subscription in subscriptions:
                if subscription.condition is not None:
                    self._wait_set.attach(subscription.condition)
            self._attached = key
        self._wait_set.wait(timeout_ns)
        self._set_guard(False)

    def _set_guard(self, triggered: bool) -> None:
        # The guard dies with the participant when the context shuts down first.
        if self._guard is not None:
            try:
                self._guard.set(triggered)
            except DDSException:
                self._guard = None


__all__ = ["SingleThreadedExecutor"]
