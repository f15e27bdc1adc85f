"""Errors of the world that describe bad user input."""

from __future__ import annotations


class WorldError(ValueError):
    """A bad world configuration, or an environment called with bad arguments."""


__all__ = ["WorldError"]
