"""Errors raised by the fire model for bad configuration."""

from __future__ import annotations


class FireConfigError(ValueError):
    """A fire-model parameter, shape name, wind or mask is not what the model accepts."""


__all__ = ["FireConfigError"]
