"""Where the networks run: ``--device cpu|cuda|auto`` of ``train``, ``eval`` and ``bench``.

No code path assumes CUDA: ``auto`` falls back to the CPU, and ``cuda`` where there is none is
a user error (one line, exit status 2), not a crash deep inside torch. The environments are
numpy and stay on the CPU; only the Q-networks, their optimiser and the replay mini-batches
move to the device (a batch is copied there as uint8 and decoded there).
"""

from __future__ import annotations

import torch

from wildfire_learning.errors import LearningError

DEVICE_CHOICES = ("cpu", "cuda", "auto")
"""What ``--device`` accepts (``cuda:N`` names one GPU of several)."""


def resolve_device(name: str) -> torch.device:
    """The torch device of ``cpu``, ``cuda``, ``cuda:N`` or ``auto`` (CUDA if present)."""
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cpu":
        return torch.device("cpu")
    if name == "cuda" or name.startswith("cuda:"):
        try:
            device = torch.device(name)
        except RuntimeError:
            raise LearningError(f"--device {name!r}: expected cpu, cuda, cuda:N or auto") from None
        if not torch.cuda.is_available():
            build = "a CPU-only build" if torch.version.cuda is None else "no GPU visible"
            raise LearningError(
                f"--device {name}: CUDA is not available here (torch {torch.__version__}, "
                f"{build}); use --device cpu or auto"
            )
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise LearningError(
                f"--device {name}: expected a GPU index below {torch.cuda.device_count()}"
            )
        return device
    raise LearningError(f"--device {name!r}: expected cpu, cuda, cuda:N or auto")


__all__ = ["DEVICE_CHOICES", "resolve_device"]
