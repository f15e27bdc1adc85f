"""How SIGINT and SIGTERM stop a wildfire process, and how the stop is recognised.

Every long-running entry point (nodes, recordings, ``wildfire run``, training) turns both
signals into ``KeyboardInterrupt`` and catches it to end cleanly: a node destroys itself, a
recording closes its bag, a training run writes its checkpoint.

One catch: the handler runs at the next Python instruction, and a compiled (numba) kernel
can run Python in the middle of its call (numba's ``_numba_unpickle``, which reads back the
constants it pickled, for instance the type of an array it returns). A signal handled there
raises inside the kernel's call, and CPython reports it as ``SystemError: ...returned a result
with an exception set`` with the ``KeyboardInterrupt`` as its cause (seen in a training run
whose teacher spends most of its time in the oracle's search kernel). :func:`stopped`
recognises both forms, so the clean ending does not depend on where the signal landed.
"""

from __future__ import annotations

import signal
from typing import Any


def _raise_keyboard_interrupt(_signum: int, _frame: Any) -> None:
    raise KeyboardInterrupt


def interrupt_on_stop_signals() -> None:
    """Turn SIGINT and SIGTERM into ``KeyboardInterrupt``: ``kill``, ``timeout``, a launcher
    or ``docker stop`` then end a node, a recording or a training run the way Ctrl-C does.

    SIGINT is set explicitly too: a process started in the background by a non-interactive
    shell inherits SIGINT *ignored*, and Python keeps it so. Such a recorder would never see
    the launcher's SIGINT (rclpy, likewise, installs its own handlers).
    """
    signal.signal(signal.SIGINT, _raise_keyboard_interrupt)
    signal.signal(signal.SIGTERM, _raise_keyboard_interrupt)


def stopped(error: BaseException) -> bool:
    """Whether ``error`` is a stop signal's ``KeyboardInterrupt``, also where it surfaced
    through a compiled kernel as the cause of a ``SystemError`` (see the module docstring)."""
    if isinstance(error, KeyboardInterrupt):
        return True
    return isinstance(error, SystemError) and isinstance(error.__cause__, KeyboardInterrupt)


__all__ = ["interrupt_on_stop_signals", "stopped"]
