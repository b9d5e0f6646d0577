"""Memory for the quasi-static tier's mapped tables, reused from one run (or streamed block) to
the next once the tables that held it are gone.

The mapped tier writes about 1.2 kB of table rows per recorded instant (23 MB per simulated
second at 20 kHz), and fresh memory for them cost about as much as computing them: each new page
is zeroed by the kernel first (system time, about 1.5 ms per simulated second here), and on a
host whose memory is fragmented a huge page may first have to be compacted, which made single
runs cost 2-10 times their median. :func:`table_arrays` lends the arrays of one table out of a
single buffer; when the last array on it is freed (the result or the streamed block dropped),
the buffer goes back to a pool, and the next table of the same size is written over it, with no
page to zero. The pool keeps at most :data:`REUSE_BYTES` of free buffers (the oldest are freed
beyond it; a larger table is never kept): that memory stays with the process after its tables
are gone, until :func:`release` or the process's end.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np

#: Largest memory of free buffers kept for the next tables, bytes: the tables of a 10 s and of a
#: 2 s mapped run at 20 kHz (220 and 44 MB), with room; a larger table is freed as usual.
REUSE_BYTES = 512 * 2**20
#: Alignment of each array in its buffer (a cache line), bytes.
_ALIGN = 64

_lock = threading.RLock()  # re-entrant: a collection inside may free a table
_free: OrderedDict[int, list[np.ndarray]] = OrderedDict()  # size -> free buffers, oldest first
_free_bytes = 0


class _Lease:
    """A buffer lent to one table's arrays (their numpy ``base``): back to the pool when the last
    of them is freed."""

    __slots__ = ("buffer",)

    def __init__(self, buffer: np.ndarray):
        self.buffer = buffer

    @property
    def __array_interface__(self) -> dict:
        return self.buffer.__array_interface__

    def __del__(self):
        try:
            _give_back(self.buffer)
        except Exception:  # the interpreter shutting down: nothing left to reuse it
            pass


def table_arrays(specs: list[tuple[tuple[int, ...], type]]) -> list[np.ndarray]:
    """Uninitialised C-contiguous arrays of the ``(shape, dtype)`` in ``specs``, carved from one
    buffer, reused when one of that size is free (see the module docstring)."""
    offsets, size = [], 0
    for shape, dtype in specs:
        offsets.append(size)
        nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
        size += -(-nbytes // _ALIGN) * _ALIGN
    memory = np.asarray(_Lease(_take(max(size, _ALIGN))))
    arrays = []
    for (shape, dtype), offset in zip(specs, offsets, strict=True):
        count = int(np.prod(shape))
        dtype = np.dtype(dtype)
        part = memory[offset : offset + count * dtype.itemsize]
        arrays.append(part.view(dtype).reshape(shape))
    return arrays


def release() -> int:
    """Free every buffer the pool keeps; returns the bytes freed."""
    global _free_bytes
    with _lock:
        freed = _free_bytes
        _free.clear()
        _free_bytes = 0
    return freed


def kept_bytes() -> int:
    """Bytes of free buffers the pool keeps."""
    return _free_bytes


def _take(size: int) -> np.ndarray:
    global _free_bytes
    with _lock:
        buffers = _free.get(size)
        if buffers:
            _free_bytes -= size
            buffer = buffers.pop()
            if not buffers:
                del _free[size]
            return buffer
    return np.empty(size, np.uint8)


def _give_back(buffer: np.ndarray) -> None:
    global _free_bytes
    size = buffer.nbytes
    if size > REUSE_BYTES:
        return
    with _lock:
        _free.setdefault(size, []).append(buffer)
        _free.move_to_end(size)
        _free_bytes += size
        while _free_bytes > REUSE_BYTES:  # the least recently returned size first
            oldest = next(iter(_free))
            _free_bytes -= oldest
            _free[oldest].pop(0)
            if not _free[oldest]:
                del _free[oldest]
