"""Node loggers printing like rclpy's default console output."""

from __future__ import annotations

import sys
import time
from typing import Any

_LEVELS = {"debug": 10, "info": 20, "warn": 30, "error": 40, "fatal": 50}
_threshold = _LEVELS["info"]


def set_global_level(level: str) -> None:
    """Threshold for every logger (``--ros-args --log-level``)."""
    global _threshold
    _threshold = _LEVELS[level]


class Logger:
    """``[INFO] [1712345678.123456789] [node]: message`` on stderr, as rclpy prints."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._once_seen: set[str] = set()
        self._last_ns: dict[str, int] = {}

    def get_child(self, name: str) -> Logger:
        """A logger named ``parent.name``."""
        return Logger(f"{self.name}.{name}")

    def get_effective_level(self) -> int:
        """The current threshold (10 debug ... 50 fatal)."""
        return _threshold

    def _log(
        self,
        level: str,
        message: Any,
        once: bool = False,
        throttle_duration_sec: float | None = None,
        **_: Any,
    ) -> bool:
        if _LEVELS[level] < _threshold:
            return False
        text = str(message)
        if once:
            if text in self._once_seen:
                return False
            self._once_seen.add(text)
        now = time.time_ns()
        if throttle_duration_sec:
            last = self._last_ns.get(text)
            if last is not None and now - last < throttle_duration_sec * 1e9:
                return False
            self._last_ns[text] = now
        sec, nsec = divmod(now, 1_000_000_000)
        print(
            f"[{level.upper()}] [{sec}.{nsec:09d}] [{self.name}]: {text}",
            file=sys.stderr,
            flush=True,
        )
        return True

    def debug(self, message: Any, **kwargs: Any) -> bool:
        """Log at DEBUG."""
        return self._log("debug", message, **kwargs)

    def info(self, message: Any, **kwargs: Any) -> bool:
        """Log at INFO."""
        return self._log("info", message, **kwargs)

    def warning(self, message: Any, **kwargs: Any) -> bool:
        """Log at WARN."""
        return self._log("warn", message, **kwargs)

    warn = warning

    def error(self, message: Any, **kwargs: Any) -> bool:
        """Log at ERROR."""
        return self._log("error", message, **kwargs)

    def fatal(self, message: Any, **kwargs: Any) -> bool:
        """Log at FATAL."""
        return self._log("fatal", message, **kwargs)


def get_logger(name: str) -> Logger:
    """As ``rclpy.logging.get_logger``."""
    return Logger(name)


__all__ = ["Logger", "get_logger", "set_global_level"]
