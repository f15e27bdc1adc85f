"""The one standard-error rule of every reported mean (episodes, paired differences, seeds).

Kept apart from ``evaluate.py`` so that figure code can use it without importing torch.
"""

from __future__ import annotations

import numpy as np


def standard_error(values: np.ndarray) -> float:
    """Standard error of the mean of ``values`` (sample standard deviation over sqrt(n));
    0 for fewer than two values, which show no spread."""
    values = np.asarray(values, dtype=np.float64)
    if values.size < 2:
        return 0.0
    return float(values.std(ddof=1) / np.sqrt(values.size))


__all__ = ["standard_error"]
