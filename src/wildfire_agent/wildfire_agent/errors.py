"""Errors raised by the agent package for bad configuration or policy files."""

from __future__ import annotations


class AgentConfigError(ValueError):
    """A policy name, policy file or agent parameter is not what the agent accepts."""


__all__ = ["AgentConfigError"]
