"""A trace too long to hold: read a CSV or Parquet trace file in chunks, or follow it as it grows.

:func:`read_chunks` yields :class:`Chunk` (time, resistance and, when asked, speed columns as
floats) of at most ``chunk_rows`` rows, so that the memory held does not depend on the file's
length: Parquet by row groups of at most :data:`GROUP_ROWS` rows (``read_row_group``, the
columns asked only), larger ones through ``iter_batches``. A row group that its writer declares
sorted by the float64 time column, ascending (Parquet's ``sorting_columns``; pyarrow:
``pq.write_table(..., sorting_columns=[pq.SortingColumn(i)])``), and whose statistics show
uniform sampling that continues the record (no nulls, a value per row, its first time one step
after the previous group's last, and its span (count - 1) steps, each within the jitter
:func:`~signatelec.measurement.traces.prepare_trace` accepts on one step) is read without its
time column, its times made uniform between its ends: the decompression of a time column is
~1/2 of the reading of a noisy record. The step is that of the times read in full (the first
row group and every group that fails the test: their span over their count, kept from before
if their steps are not uniform). The assumption: within a row group declared sorted whose ends
and count agree with uniform sampling, the samples are uniform; a dropout changes the ends or
the count of its group (read in full, its gap found). Rows out of order are refused as before
in any group not declared sorted (the ends and count of a reversed or shuffled group are those
of an ordered one, so the statistics alone cannot tell). What goes unseen in a group declared
sorted: a NaN time (not a null; it would have been dropped and its neighbours interpolated onto
a uniform grid), a repeated time beside a missing one, and jitter between its ends.

CSV (maybe compressed by gzip, bzip2 or xz, decompressed as it is read) as blocks of whole
lines parsed by pandas with the header of the file. The columns are
checked and converted as :func:`signatelec.measurement.files.read_trace` does
(:func:`~signatelec.measurement.files.check_columns`,
:func:`~signatelec.measurement.files.numeric_column`): one-line :class:`TraceError`.

``follow=True`` (CSV only: a Parquet file is unreadable until its writer closes it) keeps
reading lines appended to the file, polling every ``poll_s``; it ends when the file has not
grown for ``idle_s`` (None: never, until the caller is interrupted). A last line without its
line break is held back until it is complete.

The path :data:`STANDARD_INPUT` (``-``) reads CSV from standard input (a live stream piped in
from a logger): blocks of whole lines as they arrive (at most :data:`STREAM_WAIT_S` of wall
time gathering one), until the end of the stream. A file named ``-`` is read as ``./-``.
"""

from __future__ import annotations

import contextlib
import io
import math
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from signatelec.measurement.files import (
    Clock,
    check_columns,
    csv_dialect,
    header_names,
    numeric_column,
    open_csv,
    trace_format,
)
from signatelec.measurement.traces import JITTER_TOLERANCE, TraceError

#: Rows per chunk: 2^18 rows of three float columns are 6 MB.
CHUNK_ROWS = 1 << 18
#: Rows of the largest Parquet row group read whole (2^21 rows of three float columns are
#: 50 MB); larger ones are read in record batches of ``chunk_rows``.
GROUP_ROWS = 1 << 21
#: Longest line read (a file whose lines end in a lone carriage return is one "line").
_LINE_BYTES = 1 << 20
#: The path that reads CSV from standard input.
STANDARD_INPUT = "-"
#: Longest wait for standard input's first bytes, whose header is checked before anything long.
_PEEK_WAIT_S = 0.2
#: Most wall time spent gathering one block of a stream before it is parsed: a slow stream's
#: lines are analysed within about this of their arrival.
STREAM_WAIT_S = 1.0


def is_standard_input(path) -> bool:
    """Whether ``path`` names standard input (:data:`STANDARD_INPUT`)."""
    return isinstance(path, str) and path == STANDARD_INPUT


def trace_label(path) -> str:
    """How messages name a trace: ``trace 'PATH'``, or ``trace on standard input``."""
    return "trace on standard input" if is_standard_input(path) else f"trace {str(path)!r}"


@dataclass(frozen=True)
class Chunk:
    """Consecutive rows of a trace file (``first_row``: the index of the first)."""

    time_s: np.ndarray
    resistance_ohm: np.ndarray
    speed_rad_s: np.ndarray | None
    first_row: int
    #: The first timestamp of a time column of timestamps, whose times are seconds after it
    #: (:class:`~signatelec.measurement.files.Clock`), as ISO 8601 text, UTC; else None.
    origin_utc: str | None = None


def _columns(time_column, resistance_column, speed_column) -> list[str]:
    return [time_column, resistance_column] + ([speed_column] if speed_column else [])


def _chunk(df, names, where, first_row, clock: Clock) -> Chunk:
    values = [
        numeric_column(df[c], c, where, first_row, clock=clock if i == 0 else None)
        for i, c in enumerate(names)
    ]
    speed = values[2] if len(values) > 2 else None
    return Chunk(values[0], values[1], speed, first_row, clock.origin_utc)


def _time_leaf(pf, name: str) -> int | None:
    """The Parquet column of a float64 time column (its statistics are read), or None."""
    import pyarrow as pa

    if pf.schema_arrow.field(name).type != pa.float64():
        return None
    schema = pf.metadata.schema
    return next((j for j in range(len(schema)) if schema.column(j).path == name), None)


def _uniform_times(meta, leaf: int, step: float, last: float) -> tuple[float, float] | None:
    """(first time, step) of a row group (``meta``, its time column the leaf ``leaf``) declared
    sorted by time and whose statistics show uniform sampling continuing the record (module
    docstring), or None when its times must be read: no ascending sort declared on the time
    column, no statistics, a null, a non-finite end, or ends and count that disagree with
    ``step`` by more than the jitter :func:`~signatelec.measurement.traces.prepare_trace`
    accepts on one step (a dropped sample moves them by a whole step), or a first time that is
    not one step after ``last``."""
    rows = meta.num_rows
    sorted_by_time = any(
        c.column_index == leaf and not c.descending for c in (meta.sorting_columns or ())
    )
    stats = meta.column(leaf).statistics
    if (
        not sorted_by_time
        or rows < 2
        or stats is None
        or not stats.has_min_max
        or not stats.has_null_count
        or stats.null_count != 0
        or stats.num_values != rows
    ):
        return None
    low, high = float(stats.min), float(stats.max)
    tolerance = JITTER_TOLERANCE * step
    if not (
        math.isfinite(low)
        and math.isfinite(high)
        and abs(low - last - step) <= tolerance
        and abs(high - low - (rows - 1) * step) <= tolerance
    ):
        return None
    return low, (high - low) / (rows - 1)


def _extent(time_s: np.ndarray) -> tuple[float, float, float, float]:
    """First and last time, smallest and largest step of a chunk read in full."""
    dt = np.diff(time_s)
    lo, hi = (float(dt.min()), float(dt.max())) if dt.size else (math.inf, -math.inf)
    return float(time_s[0]), float(time_s[-1]), lo, hi


def _record_step(extents, rows: int) -> float | None:
    """The step of a row group read in full (``extents`` of its chunks): its span over its
    count, where every step is within the jitter tolerance of it (a step from the span is
    exact to the rounding of two times over the count, a median to that of one step); None
    if it is not uniform (a gap, a rate change: the record's step is kept)."""
    first, last = extents[0][0], extents[-1][1]
    step = (last - first) / (rows - 1) if rows > 1 else math.nan
    joins = [b[0] - a[1] for a, b in zip(extents, extents[1:], strict=False)]
    lo, hi = min([e[2] for e in extents] + joins), max([e[3] for e in extents] + joins)
    if not (step > 0.0 and max(hi - step, step - lo) <= JITTER_TOLERANCE * step):
        return None
    return step


def _parquet_file(path, names, where):
    """The open Parquet file, its columns checked (its footer read, no rows)."""
    import pyarrow.parquet as pq

    try:
        # without pre-buffering: with it, pyarrow keeps every column chunk read so far (the
        # memory held grew by ~0.25 MB per second of a 50 kHz trace)
        pf = pq.ParquetFile(path, pre_buffer=False)
    except (OSError, ValueError) as exc:
        raise TraceError(f"{where}: cannot be read as parquet ({_first(exc)})") from None
    check_columns(pf.schema_arrow.names, names, where)
    return pf


def _parquet_chunks(path, names, where, chunk_rows) -> Iterator[Chunk]:
    pf = _parquet_file(path, names, where)
    clock = Clock()
    leaf = _time_leaf(pf, names[0])
    row, step, last = 0, None, None  # the record's step and last time, from times read
    for group in range(pf.num_row_groups):
        meta = pf.metadata.row_group(group)
        size = meta.num_rows
        made = None  # (first time, step) of a group whose times are made, not read
        if leaf is not None and step is not None:
            made = _uniform_times(meta, leaf, step, last)
        columns = names if made is None else names[1:]
        if size <= GROUP_ROWS:
            # a whole row group read at once, cut into chunks without copying: ~0.6x the
            # time of the record batches (measured on 1e6-row groups)
            table = pf.read_row_group(group, columns=columns, use_threads=False)
            parts = (table.slice(i, chunk_rows) for i in range(0, size, chunk_rows))
        else:
            parts = pf.iter_batches(
                batch_size=chunk_rows, row_groups=[group], columns=columns, use_threads=False
            )
        offset, extents = 0, []
        for part in parts:
            times = None
            if made is not None:
                times = made[0] + made[1] * np.arange(offset, offset + part.num_rows, dtype=float)
            chunk = _arrow_chunk(part, names, where, row, clock, times)
            if made is None:
                extents.append(_extent(chunk.time_s))
            yield chunk
            row += part.num_rows
            offset += part.num_rows
        if made is not None:
            last = float(meta.column(leaf).statistics.max)
        elif extents:
            step, last = _record_step(extents, offset) or step, extents[-1][1]


def _arrow_chunk(batch, names, where, first_row, clock: Clock, time_s=None) -> Chunk:
    """A chunk of a record batch or table slice: numeric columns cast to floats in Arrow
    (missing -> NaN), without the detour through pandas that costs ~0.1 us a row (a float
    column without missing values is not copied: read-only views of the Arrow buffers); any
    other column through
    :func:`~signatelec.measurement.files.numeric_column` (its one-line refusal of text).
    ``time_s``: the rows' times when the batch holds no time column (``names[0]``)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    read = names if time_s is None else names[1:]
    columns = [batch.column(batch.schema.get_field_index(c)) for c in read]
    if not all(pa.types.is_floating(c.type) or pa.types.is_integer(c.type) for c in columns):
        frame = batch.to_pandas()
        if time_s is not None:
            frame[names[0]] = time_s
        return _chunk(frame, names, where, first_row, clock)
    values = [pc.cast(c, pa.float64(), safe=False).to_numpy(zero_copy_only=False) for c in columns]
    if time_s is not None:
        values.insert(0, time_s)
    return Chunk(values[0], values[1], values[2] if len(values) > 2 else None, first_row)


def _first(exc: BaseException) -> str:
    """The first line of an exception's message (its type when it has none)."""
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


def _header(fh, follow: bool, poll_s: float, where: str, idle_s: float | None = None) -> bytes:
    """The first complete line that is neither blank nor a comment (waiting for it when
    following a file being written, at most ``idle_s`` without growth)."""
    idle_since, size = time.monotonic(), None
    while True:
        pos = fh.tell() if follow else 0  # (a stream cannot tell)
        line = fh.readline(_LINE_BYTES)
        _check_line_ends(line, where, 0)
        if not line.endswith(b"\n"):
            if not follow:
                if line.strip() and not line.startswith(b"#"):
                    return line + b"\n"
                raise TraceError(f"{where}: cannot be read as csv (no header line)")
            fh.seek(pos)
            if size != pos + len(line):
                idle_since, size = time.monotonic(), pos + len(line)
            elif idle_s is not None and time.monotonic() - idle_since > idle_s:
                raise TraceError(
                    f"{where}: cannot be read as csv (no header line; the file did not grow "
                    f"for --idle {idle_s:g} s)"
                )
            time.sleep(poll_s)
            continue
        if line.strip() and not line.startswith(b"#"):
            return line


def _check_line_ends(text: bytes, where: str, row: int) -> None:
    """TraceError when ``text``, bytes of a CSV file not yet cut into lines (from ``row`` on),
    shows text lines ending in a carriage return alone (the old Mac convention: the whole
    file is one "line" to a reader of lines), or holds :data:`_LINE_BYTES` without a line
    break."""
    body = text.rstrip(b"\r\n")
    if b"\r" in body:
        try:
            body[:4096].decode("utf-8")
        except UnicodeDecodeError:  # not text: its reader says why
            return
        raise TraceError(
            f"{where}: cannot be read as csv near row {row} (its lines end in a carriage return "
            "alone, the old Mac convention); convert them to LF or CRLF line ends"
        )
    if len(text) >= _LINE_BYTES and b"\n" not in text:
        raise TraceError(
            f"{where}: cannot be read as csv near row {row} (no line break in {len(text)} bytes)"
        )


@contextlib.contextmanager
def _open(path, where, compression=None):
    """A CSV file open for reading bytes; of a compressed one, the errors of a damaged or
    truncated stream met while it is read are one line (TraceError)."""
    import lzma
    import zlib

    try:
        fh = open_csv(path, compression)
    except OSError as exc:
        raise TraceError(f"{where}: cannot be read ({exc.strerror or _first(exc)})") from None
    with fh:
        try:
            yield fh
        except (EOFError, OSError, lzma.LZMAError, zlib.error) as exc:
            if compression is None:
                raise
            raise TraceError(
                f"{where}: cannot be read as csv{compression} (damaged or truncated: {_first(exc)})"
            ) from None


def _csv_header(fh, names, where, follow, poll_s, idle_s) -> tuple[bytes, tuple[str, str]]:
    """(header line, (separator, decimal mark)) of a CSV file or stream, its columns checked;
    ``fh`` left after the header (the dialect read from the header and the lines after it,
    those of a stream as far as they have arrived)."""

    header = _header(fh, follow, poll_s, where, idle_s)
    if fh.seekable():
        start = fh.tell()
        after = fh.read(4096)
        fh.seek(start)
    else:
        after = fh.peek(4096)[:4096]
    return header, _checked_header(header, after, names, where)


def _checked_header(header: bytes, after: bytes, names, where) -> tuple[str, str]:
    """The separator and decimal mark of a CSV header line
    (:func:`~signatelec.measurement.files.csv_dialect` of it and ``after``, the bytes that
    follow it), its columns checked."""
    import pandas as pd

    sep, decimal = csv_dialect(header + after)
    try:
        columns = header_names(io.BytesIO(header), sep=sep)
    except (ValueError, pd.errors.ParserError) as exc:
        # UnicodeDecodeError is a ValueError: a binary file given as CSV
        raise TraceError(f"{where}: cannot be read as csv (header line: {_first(exc)})") from None
    check_columns(columns, names, where)
    return sep, decimal


def _peeked_header(names, where) -> None:
    """Check the header line of standard input among the bytes that have arrived, without
    taking them from the stream; nothing if none has within :data:`_PEEK_WAIT_S` (a logger
    that waits for a trigger, a terminal: what else can be checked is not held up), or the
    header line is not all there."""
    import select

    stream = getattr(sys.stdin, "buffer", None)
    if getattr(stream, "peek", None) is None or stream.isatty():
        return
    try:
        if not select.select([stream], [], [], _PEEK_WAIT_S)[0]:
            return
    except (OSError, ValueError):  # (a stream that cannot be waited on)
        return
    lines = stream.peek(_LINE_BYTES).split(b"\n")
    for i, line in enumerate(lines[:-1]):  # (complete lines only)
        if line.strip() and not line.startswith(b"#"):
            _checked_header(line + b"\n", b"\n".join(lines[i + 1 :])[:4096], names, where)
            return


def _csv_chunks(
    path, names, where, chunk_rows, follow, poll_s, idle_s, compression=None
) -> Iterator[Chunk]:
    if path is None:
        yield from _csv_rows(sys.stdin.buffer, names, where, chunk_rows, False, poll_s, None)
        return
    with _open(path, where, compression) as fh:
        yield from _csv_rows(fh, names, where, chunk_rows, follow, poll_s, idle_s)


def _block(fh, size: int) -> bytes:
    """Up to ``size`` bytes of ``fh``; of a stream, those that arrive within
    :data:`STREAM_WAIT_S` of the first (waiting for the first as long as it takes; b"" at the
    stream's end)."""
    if fh.seekable():
        return fh.read(size)
    parts, got, until = [], 0, math.inf
    while got < size:
        if parts and not _arrives(fh, until - time.monotonic()):
            break
        part = fh.read1(size - got)
        if not part:
            break
        parts.append(part)
        got += len(part)
        until = min(until, time.monotonic() + STREAM_WAIT_S)
    return b"".join(parts)


def _arrives(fh, wait_s: float) -> bool:
    """Whether ``fh`` has bytes to read within ``wait_s`` (select; True where a stream cannot
    be waited on, whose read then blocks)."""
    import select

    try:
        return bool(select.select([fh], [], [], max(wait_s, 0.0))[0])
    except (OSError, ValueError):
        return True


def _csv_rows(fh, names, where, chunk_rows, follow, poll_s, idle_s) -> Iterator[Chunk]:
    import pandas as pd

    block_bytes = 40 * chunk_rows  # ~40 bytes per line of three numbers
    header, _ = _csv_header(fh, names, where, follow, poll_s, idle_s)
    clock = Clock()
    row, pending, idle_since = 0, b"", time.monotonic()
    dialect = None  # read from the first lines parsed: a file followed from before its logger
    # writes them has only its header when it is opened
    while True:
        data = _block(fh, block_bytes)
        if data:
            idle_since = time.monotonic()
            data = pending + data
            cut = data.rfind(b"\n") + 1
            pending, data = data[cut:], data[:cut]
            _check_line_ends(pending, where, row)
            if not data:
                continue
        elif not follow:
            data, pending = pending, b""
            if not data.strip():
                return
        else:
            if idle_s is not None and time.monotonic() - idle_since > idle_s:
                return
            time.sleep(poll_s)
            continue
        if dialect is None:
            dialect = _checked_header(header, data[:4096], names, where)
        sep, decimal = dialect
        try:
            df = pd.read_csv(
                io.BytesIO(header + data),
                sep=sep,
                decimal=decimal,
                comment="#",
                usecols=list(names),
                encoding_errors="replace",
            )
        except (ValueError, pd.errors.ParserError) as exc:
            raise TraceError(
                f"{where}: cannot be read as csv near row {row} ({_first(exc)})"
            ) from None
        if len(df):
            yield _chunk(df, names, where, row, clock)
            row += len(df)


def _checked(path, time_column, resistance_column, speed_column, follow):
    """(path, where, names, format, compression) of a trace file
    (:func:`~signatelec.measurement.files.trace_format`): refused if it is no file, of an
    unknown format, or asks one column twice; (None, ..., "csv", None) for standard input."""
    where = trace_label(path)
    names = _columns(time_column, resistance_column, speed_column)
    if len(set(names)) < len(names):
        raise TraceError(f"{where}: the time, resistance and speed columns must differ ({names})")
    if is_standard_input(path):
        return None, where, names, "csv", None
    p = Path(path)
    if p.is_dir():
        raise TraceError(f"{where}: is a directory; give a .csv or .parquet file")
    if not p.is_file():
        raise TraceError(f"{where}: no such file")
    kind, compression = trace_format(p, where)
    if follow and (kind == "parquet" or compression):
        what = "a Parquet file" if kind == "parquet" else "a compressed file"
        raise TraceError(
            f"{where}: --follow reads a CSV file as it grows; {what} cannot be read before its "
            "writer closes it"
        )
    return p, where, names, kind, compression


def check_trace_file(
    path: str | Path,
    time_column: str = "time_s",
    resistance_column: str = "resistance_ohm",
    speed_column: str | None = None,
    *,
    follow: bool = False,
) -> None:
    """Refuse (TraceError, the line :func:`read_chunks` would give) what can be told of a trace
    file without reading its rows: it exists, is readable, of a known format, its columns are
    there (a Parquet footer, a CSV header line; a file being followed may not have its header
    yet, and is not waited for; standard input's is read if it has arrived, and left in the
    stream). Cheap: run it before anything long."""
    p, where, names, kind, compression = _checked(
        path, time_column, resistance_column, speed_column, follow
    )
    if kind == "parquet":
        _parquet_file(p, names, where)
    elif p is None:
        _peeked_header(names, where)
    elif not follow and p is not None:
        with _open(p, where, compression) as fh:
            _csv_header(fh, names, where, False, 0.0, None)


def read_chunks(
    path: str | Path,
    time_column: str = "time_s",
    resistance_column: str = "resistance_ohm",
    speed_column: str | None = None,
    *,
    chunk_rows: int = CHUNK_ROWS,
    follow: bool = False,
    poll_s: float = 0.2,
    idle_s: float | None = None,
) -> Iterator[Chunk]:
    """The rows of a trace file, ``chunk_rows`` at a time (module docstring)."""
    p, where, names, kind, compression = _checked(
        path, time_column, resistance_column, speed_column, follow
    )
    if kind == "parquet":
        return _parquet_chunks(p, names, where, chunk_rows)
    return _csv_chunks(p, names, where, chunk_rows, follow, poll_s, idle_s, compression)
