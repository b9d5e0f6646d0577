"""A trace file as it is written: its format (CSV, maybe compressed, or Parquet), a CSV's
dialect (separator, decimal mark), its columns and their cells (numbers; for the time,
timestamps too), read by :func:`read_trace` whole and by :mod:`signatelec.measurement.stream`
in chunks, each refusal one line (:class:`~signatelec.measurement.traces.TraceError`)."""

from __future__ import annotations

import csv
import lzma
import re
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from signatelec.measurement.traces import TraceError


class TraceColumns(NamedTuple):
    """The columns of a trace file: time (s), resistance (ohm), and the simulation phase of
    each row when the file has a ``phase`` column (else None)."""

    time_s: np.ndarray
    resistance_ohm: np.ndarray
    phase: np.ndarray | None = None


def check_columns(columns, wanted, where: str, options: dict | None = None) -> None:
    """TraceError naming the first of ``wanted`` missing from ``columns``, or found more than
    once (a CSV file's :func:`header_names`, not pandas' renamed columns), and the option that
    names it (``options``: column -> option; by default the time and resistance options,
    whatever the names given, in the order time, resistance, then ``--speed-column``)."""
    columns = list(columns)
    default = ("--time-column", "--resistance-column", "--speed-column")
    for i, column in enumerate(wanted):
        if columns.count(column) > 1:
            raise TraceError(
                f"{where}: {columns.count(column)} columns named {column!r}; which one is meant "
                "cannot be told: give each column its own name"
            )
        if column not in columns:
            option = (options or {}).get(column, default[min(i, len(default) - 1)])
            # repr: a name holding a line break or control character stays on the one line
            have = ", ".join(map(repr, columns[:8])) + (", ..." if len(columns) > 8 else "")
            raise TraceError(
                f"{where}: no column {column!r} (columns: {have or 'none'}); name it with {option}"
            )


def header_names(source, **read_csv) -> list[str]:
    """The names of a CSV file's header as written (a frame's columns rename a repeated "x" to
    "x.1", "x.2", ..., which a real name may also be): its first row read as text."""
    import pandas as pd

    row = pd.read_csv(source, header=None, nrows=1, dtype=str, keep_default_na=False, **read_csv)
    return [str(c) for c in row.iloc[0]] if len(row) else []


#: A number written with a decimal comma (a spreadsheet's export in a European locale).
_DECIMAL_COMMA = re.compile(r"^\s*[-+]?(\d+,\d*|,\d+)([eE][-+]?\d+)?\s*$")


def csv_dialect(head: bytes) -> tuple[str, str]:
    """(separator, decimal mark) of a CSV file from its first bytes: the separator sniffed
    among ``, ; tab space`` from its first 20 lines that are not comments (``,`` when the
    sniffer finds none); the decimal mark ``,`` when the separator is not one and a cell of
    those lines is a number written with a decimal comma (``0,0025;...``, a spreadsheet's
    export in a European locale), else ``.``."""
    lines = [x for x in head.decode("utf-8", "replace").splitlines() if not x.startswith("#")]
    lines = lines[:20]
    try:
        sep = csv.Sniffer().sniff("\n".join(lines), delimiters=",;\t ").delimiter
    except csv.Error:
        sep = ","
    comma = sep != "," and any(
        _DECIMAL_COMMA.match(cell) for line in lines[1:] for cell in line.split(sep)
    )
    return sep, "," if comma else "."


def _refuse_text(raw, read, column: str, where: str, first_row: int, allowed: str) -> None:
    """TraceError naming the first cell of ``raw`` that ``read`` (its reading, NaN or NaT
    where it failed) could not read and that is neither empty nor "nan"."""
    text = read.isna() & raw.notna()
    if text.any():
        text &= ~raw.astype(str).str.strip().str.lower().isin(("nan", ""))
    if text.any():
        row = int(np.flatnonzero(text.to_numpy())[0])
        raise TraceError(
            f"{where}: column {column!r} holds text at row {first_row + row} "
            f"({str(raw.iloc[row])[:20]!r}); {allowed} only (empty or nan for a missing sample)"
        )


#: A day, s.
DAY_S = 86400.0


@dataclass
class Clock:
    """A time column of timestamps is read as seconds after its first timestamp,
    ``origin_ns`` (ns since 1970-01-01 UTC; set by the first read): exact, where seconds since
    1970 as doubles round to 0.24 us, 2.4 % of a step at 100 kHz (a step read off such times
    after one missing sample resampled a record at 99864 Hz)."""

    origin_ns: int | None = None
    #: Days a time of day has passed midnight, and its last time read (s after midnight).
    days: int = 0
    last_of_day_s: float | None = None

    def of_day(self, seconds: np.ndarray) -> np.ndarray:
        """Times of day (s after midnight, every one below a day) as seconds after the first
        day's midnight, in place and across reads: a time that goes back more than half a day
        is the next day's (a logger's clock without a date runs past midnight; a time that goes
        back less is refused later, as any time that goes back is)."""
        read = np.flatnonzero(np.isfinite(seconds))
        if read.size == 0:
            return seconds
        t = seconds[read]
        before = t[0] if self.last_of_day_s is None else self.last_of_day_s
        previous = np.concatenate(([before], t[:-1]))
        days = self.days + np.cumsum(t < previous - DAY_S / 2)
        self.last_of_day_s, self.days = float(t[-1]), int(days[-1])
        seconds[read] = t + DAY_S * days
        return seconds

    @property
    def origin_utc(self) -> str | None:
        """The origin as ISO 8601 text, UTC (None before a timestamp is read)."""
        import pandas as pd

        return (
            None if self.origin_ns is None else pd.Timestamp(self.origin_ns, tz="UTC").isoformat()
        )


#: Cells of a time column read as text: a timestamp's comma fraction (ISO 8601 allows it).
_COMMA_FRACTION = r"(\d{2}:\d{2}:\d{2}),(\d)"


def _point_fractions(raw):
    """A text column with each time's comma fraction written with a point, in every cell (a
    writer that drops a zero fraction starts on a whole second; pandas reads '10:00:00,000050'
    as a duration of 50 s): Arrow's regular expressions, ~0.2 us a cell, where pandas' took
    ~1.5 us, 3x the rest of the reading of a timestamped CSV."""
    import pandas as pd
    import pyarrow as pa
    import pyarrow.compute as pc

    try:
        cells = pa.array(raw.astype(object), from_pandas=True, type=pa.string())
    except (pa.ArrowInvalid, pa.ArrowTypeError):  # (cells of other types: read as text)
        cells = pa.array(raw.astype(str), type=pa.string())
    fixed = pc.replace_substring_regex(cells, pattern=_COMMA_FRACTION, replacement=r"\1.\2")
    return pd.Series(fixed.to_pandas(), index=raw.index)


def _refuse_bare_numbers(raw, column: str, where: str, first_row: int) -> None:
    """TraceError naming the first cell of a text column of times of day or durations that is
    a bare whole number (pandas reads '2' beside '1 days' as 2 ns)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    cells = pa.array(raw.astype(object), from_pandas=True, type=pa.string())
    bare = pc.match_substring_regex(cells, pattern=r"^\s*[-+]?\d+\s*$").fill_null(False)
    if pc.any(bare).as_py():
        row = int(np.flatnonzero(bare.to_numpy(zero_copy_only=False))[0])
        raise TraceError(
            f"{where}: column {column!r} holds a bare number at row {first_row + row} "
            f"({str(raw.iloc[row])[:20]!r}) among times of day or durations; write every time "
            "alike"
        )


def _seconds(raw, column: str, where: str, first_row: int, clock: Clock) -> np.ndarray | None:
    """A time column of timestamps or durations as seconds, or None when it holds numbers:
    datetime64 (a Parquet timestamp, tz-aware or not) and ISO 8601 text (a time without zone
    read as UTC; a comma fraction read as a point) as seconds after ``clock``'s origin,
    timedelta64 and text of a time of day or a duration ('10:00:00.5', '0 days 00:00:01') as
    seconds (a time of day's after its first day's midnight, past midnight too:
    :meth:`Clock.of_day`); missing -> NaN.
    Text that is neither a number nor a timestamp is refused naming its row."""
    import pandas as pd

    kind = raw.dtype
    if pd.api.types.is_timedelta64_dtype(kind):
        return raw.dt.total_seconds().to_numpy(dtype=float)
    if not pd.api.types.is_datetime64_any_dtype(kind):
        if not (pd.api.types.is_object_dtype(kind) or pd.api.types.is_string_dtype(kind)):
            return None
        # the first cell that holds something (the others are read alike)
        cells = (str(c).strip() for c in raw if pd.notna(c))
        first = next((c for c in cells if c.lower() not in ("nan", "")), "0")
        try:
            float(first)
            return None  # numbers (or text refused as such)
        except ValueError:
            pass
        raw = _point_fractions(raw)
        stamps = pd.to_datetime(raw, format="ISO8601", utc=True, errors="coerce")
        if stamps.isna().all():  # a time of day ('10:00:00.5') or a duration, as seconds
            lasted = pd.to_timedelta(raw, errors="coerce")
            if lasted.isna().all():
                return None
            _refuse_text(raw, lasted, column, where, first_row, CLOCK_CELLS)
            _refuse_bare_numbers(raw, column, where, first_row)
            seconds = lasted.dt.total_seconds().to_numpy(dtype=float, copy=True)
            of_day = np.all((seconds >= 0.0) & (seconds < DAY_S) | np.isnan(seconds))
            return clock.of_day(seconds) if of_day else seconds
        _refuse_text(raw, stamps, column, where, first_row, CLOCK_CELLS)
        raw = stamps
    if isinstance(raw.dtype, pd.DatetimeTZDtype):
        raw = raw.dt.tz_convert("UTC").dt.tz_localize(None)
    ns = raw.to_numpy("datetime64[ns]")
    missing = np.isnat(ns)
    ns = ns.astype(np.int64)
    if clock.origin_ns is None and not missing.all():
        clock.origin_ns = int(ns[~missing][0])
    out = (ns - (clock.origin_ns or 0)).astype(float) / 1e9
    out[missing] = np.nan
    return out


#: What a time column may hold.
CLOCK_CELLS = "seconds or ISO 8601 timestamps"


def numeric_column(
    raw, column: str, where: str, first_row: int = 0, clock: Clock | None = None
) -> np.ndarray:
    """A column as floats: empty cells and "nan" become NaN (missing samples, repaired or
    refused later), other text is refused naming its row (counted from ``first_row``).
    ``clock``: of the time column, whose timestamps or durations are read as seconds
    (:func:`_seconds`)."""
    import pandas as pd

    if (
        clock is not None
        and (seconds := _seconds(raw, column, where, first_row, clock)) is not None
    ):
        return seconds
    if pd.api.types.is_datetime64_any_dtype(raw.dtype) or pd.api.types.is_timedelta64_dtype(
        raw.dtype
    ):
        raise TraceError(f"{where}: column {column!r} holds timestamps or durations; numbers only")
    try:
        number = pd.to_numeric(raw, errors="coerce")
    except OverflowError:  # an integer cell beyond the float range, read as a Python int
        number = pd.to_numeric(raw.astype(str), errors="coerce")  # +-inf, as "1e400" is
    _refuse_text(raw, number, column, where, first_row, "numbers" if clock is None else CLOCK_CELLS)
    return number.to_numpy(dtype=float)


#: Suffixes of a trace file of each format.
PARQUET_SUFFIXES = (".parquet", ".pq")
CSV_SUFFIXES = (".csv", ".txt", ".tsv")
#: Compressions a CSV file may be written with (a logger's long records): its last suffix.
COMPRESSED_SUFFIXES = (".gz", ".bz2", ".xz")


def trace_format(path: Path, where: str) -> tuple[str, str | None]:
    """("csv" or "parquet", the compression's suffix or None) of a trace file, from its
    suffixes (a CSV file compressed by gzip, bzip2 or xz: ``.csv.gz``, ``.csv.bz2``,
    ``.csv.xz``), or TraceError naming the format that is not known."""
    suffixes = [x.lower() for x in path.suffixes[-2:]]
    last = suffixes[-1] if suffixes else ""
    if last in PARQUET_SUFFIXES:
        return "parquet", None
    if last in CSV_SUFFIXES:
        return "csv", None
    if last in COMPRESSED_SUFFIXES and len(suffixes) == 2 and suffixes[0] in CSV_SUFFIXES:
        return "csv", last
    name = "".join(suffixes) if last in COMPRESSED_SUFFIXES else last
    raise TraceError(
        f"{where}: unknown format {name or '(none)'!r}; give .csv or .parquet (a CSV file may be "
        f"compressed: {', '.join('.csv' + c for c in COMPRESSED_SUFFIXES)})"
    )


def open_csv(path: Path, compression: str | None):
    """A CSV trace file opened for reading bytes, decompressed as it is read."""
    import bz2
    import gzip
    import lzma

    opener = {None: open, ".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}[compression]
    return opener(path, "rb")


def read_trace(
    path: str | Path,
    time_column: str = "time_s",
    resistance_column: str = "resistance_ohm",
    phase_column: str = "phase",
) -> TraceColumns:
    """The time and resistance columns of a CSV (``.csv``, ``.txt``, ``.tsv``, maybe compressed:
    :func:`trace_format`) or Parquet file, as floats
    (cells that are not numbers become NaN), and its ``phase_column`` if it has one. Raises
    TraceError naming the file."""
    import pandas as pd

    p = Path(path)
    where = f"trace {str(path)!r}"
    if not p.is_file():
        raise TraceError(f"{where}: no such file")
    kind, compression = trace_format(p, where)
    try:
        if kind == "parquet":
            df = pd.read_parquet(p)
        else:
            with open_csv(p, compression) as fh:
                sep, decimal = csv_dialect(fh.read(1 << 16))
            # (a byte that is not UTF-8 in a column not read, a logger's note, is no matter; in
            # one that is read, it is text there, refused as such)
            df = pd.read_csv(p, sep=sep, decimal=decimal, comment="#", encoding_errors="replace")
            header = header_names(p, sep=sep, comment="#")  # (UTF-8, as the monitor reads it)
    except (
        OSError,
        EOFError,
        ValueError,
        pd.errors.ParserError,
        csv.Error,
        lzma.LZMAError,
        zlib.error,
    ) as exc:
        # csv.Error: the delimiter sniffer finds no column separator (an empty file, one cell);
        # OSError, EOFError, LZMAError, zlib.error: a damaged or truncated compressed file
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise TraceError(f"{where}: cannot be read as {kind}{compression or ''} ({text})") from None
    wanted = (time_column, resistance_column)
    if kind == "parquet":
        check_columns(df.columns, wanted, where)
    else:
        check_columns(header, wanted, where)
    clock = Clock()
    values = [
        numeric_column(df[c], c, where, clock=clock if i == 0 else None)
        for i, c in enumerate(wanted)
    ]
    phase = df[phase_column].astype(str).to_numpy() if phase_column in df.columns else None
    return TraceColumns(values[0], values[1], phase)
