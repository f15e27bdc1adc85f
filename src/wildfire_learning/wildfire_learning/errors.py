"""Errors of the learning package that describe bad user input."""

from __future__ import annotations


class LearningError(ValueError):
    """A bad training/evaluation argument, checkpoint or bag for training."""


__all__ = ["LearningError"]
