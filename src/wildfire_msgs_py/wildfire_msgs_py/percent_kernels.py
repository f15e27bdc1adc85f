"""The shared belief's percent rounding as compiled loops (numba), for
:mod:`wildfire_msgs_py.belief_codec`.

A filtered belief is published, and shown to belief networks, every decision: 640 000 cells
at 64 episodes. The rule, one pass per cell here, took nine whole-array passes and four
temporaries in numpy. The arithmetic is the numpy rule's, operation for operation (float64
clip, times 100, round half to even), so the grids are bit-identical to it.

Both kernels live in this one file: numba's disk cache (``cache=True``) checks only the
source file of the function it compiled.
"""

from __future__ import annotations

import numba
import numpy as np

from wildfire_msgs_py.codecs import BELIEVED_ABOVE, FIRE_BURNING

_inlined = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
_kernel = numba.njit(cache=True, nogil=True, error_model="numpy")


@_inlined
def _percent(believed: bool, probability: float) -> float:
    # Whole percent, rounded half to even, but on the believed side of 50: "> 50" is exactly
    # what the team believes burning.
    percent = np.rint(min(max(probability, 0.0), 1.0) * float(FIRE_BURNING))
    if believed:
        return max(percent, float(BELIEVED_ABOVE + 1))
    return min(percent, float(BELIEVED_ABOVE))


@_kernel
def percent_grid(believed: np.ndarray, probability: np.ndarray, out: np.ndarray) -> None:
    """``out[i]`` (int8) = the published percent of cell i (flat arrays of one size)."""
    for i in range(out.size):
        out[i] = np.int8(_percent(believed[i], probability[i]))


@_kernel
def published_grid(believed: np.ndarray, probability: np.ndarray, out: np.ndarray) -> None:
    """``out[i]`` (float32) = the published percent of cell i / 100: what a network sees."""
    scale = np.float32(FIRE_BURNING)
    for i in range(out.size):
        out[i] = np.float32(_percent(believed[i], probability[i])) / scale


def compile_kernels() -> None:
    """Compile (or load from the disk cache) every kernel of this module."""
    believed, probability = np.ones(1, bool), np.ones(1)
    percent_grid(believed, probability, np.zeros(1, np.int8))
    published_grid(believed, probability, np.zeros(1, np.float32))


__all__ = ["compile_kernels", "percent_grid", "published_grid"]
