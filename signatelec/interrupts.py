"""Ctrl-C and SIGTERM: what must not be cut short (:func:`signals_deferred`), and a Ctrl-C that
comes back wrapped (:func:`interruption`)."""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager


def interruption(exc: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C (or SIGTERM, raised alike) that ``exc`` is, or that a SystemError carries: a
    KeyboardInterrupt raised inside a compiled function's first call (numba loading it from
    its cache) comes back as "returned a result with an exception set"; None otherwise."""
    if isinstance(exc, KeyboardInterrupt):
        return exc
    stop = (exc.__cause__ or exc.__context__) if isinstance(exc, SystemError) else None
    return stop if isinstance(stop, KeyboardInterrupt) else None


@contextmanager
def signals_deferred():
    """Ctrl-C and SIGTERM ignored within the block (in the main thread; signals reach only it):
    for what must not be cut short, an output's exchange and what follows a written output."""
    main = threading.current_thread() is threading.main_thread()
    kept = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM) if main}
    try:
        yield
    finally:
        for s, handler in kept.items():
            signal.signal(s, handler)
