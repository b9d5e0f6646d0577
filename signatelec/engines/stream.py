"""Tables written as a run goes: blocks of recorded instants appended to Parquet row groups.

An engine given a :class:`TableStream` hands it the ``balls`` and ``signals`` tables of each
block of at most :data:`STREAM_BLOCK_INSTANTS` recorded instants as soon as the block is
computed; each block becomes one row group of ``balls.parquet`` and ``signals.parquet``, so the
memory of a run is bounded by one block whatever its duration. The files live in the temporary
directory of :func:`signatelec.io.replace_directory` until the run ends: a killed run leaves no
output, and its files have no Parquet footer, so they do not read as complete. The schema
metadata (the scene, the version and the run's timings, as :func:`signatelec.io.write_result`
writes them) is known at the end only, so it is written with the footer.

The steady-phase means of the signal columns (what a run's summary prints) are kept on the way:
a streamed result holds no tables.

An engine hands its blocks as numpy columns (``phase`` as codes into
:data:`~signatelec.engines.results.PHASES`): they go to Arrow directly, with the pandas metadata
pyarrow would write for the same DataFrame (:func:`pandas_metadata`), so a streamed run never
imports pandas and its files read back as the in-memory tables. DataFrames are accepted too.
"""

from __future__ import annotations

import base64
import glob
import importlib.util
import json
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from signatelec.config.scene import Scene
from signatelec.engines.results import PHASES, in_steady_phase

if TYPE_CHECKING:
    import pandas as pd
    import pyarrow as pa

#: Recorded instants per block: the buffer the kernel records into, and one row group. At the
#: budget's ~5.7 kB per instant of the seed's bearing (record arrays, tables, electrical
#: network), about 50 MB.
STREAM_BLOCK_INSTANTS = 8192


class TableStream:
    """Receives the tables of a run block by block and appends them to Parquet files in
    ``directory`` (``balls.parquet``, ``signals.parquet``)."""

    def __init__(self, directory: str | Path, scene: Scene):
        self.directory = Path(directory)
        self.scene = scene
        self._writers: dict = {}
        self._schemas: dict = {}
        self._sums: dict[str, float] = {}
        self._counts: dict[str, int] = {}
        self.n_instants = 0

    def write(self, balls, signals) -> None:
        """Append one block (the rows of its recorded instants, in time order): Arrow tables
        (:func:`arrow_table`), numpy columns by name (``phase`` as codes) or DataFrames."""
        import pyarrow.parquet as pq

        if self.scene.effects.lubrication != "none":
            # the lubricated columns are post-processing of each block's kinematics and loads
            from signatelec.engines.lubrication import lubricate_tables

            balls, signals = (_frame(t) for t in (balls, signals))
            lubricate_tables(self.scene, balls, signals)
        tables = {"balls": arrow_table(balls), "signals": arrow_table(signals)}
        for name, table in tables.items():
            writer = self._writers.get(name)
            if writer is None:
                # the Arrow schema is stored with the metadata at the end (finish)
                path = self.directory / f"{name}.parquet"
                writer = pq.ParquetWriter(path, table.schema, store_schema=False)
                self._writers[name] = writer
                self._schemas[name] = table.schema
            writer.write_table(table)
        signals = tables["signals"]
        self.n_instants += signals.num_rows
        steady = in_steady_phase(arrow_numbers(signals.column("time_s")), self.scene)
        for column in signals.column_names:
            if column == "phase":
                continue
            values = arrow_numbers(signals.column(column))
            if values is None:
                continue
            values = values[steady].astype(float, copy=False)
            finite = ~np.isnan(values)
            self._sums[column] = self._sums.get(column, 0.0) + float(values[finite].sum())
            self._counts[column] = self._counts.get(column, 0) + int(finite.sum())

    def steady_means(self) -> dict[str, float]:
        """Mean of each numeric signal column over the steady phase (NaN skipped, as pandas)."""
        return {c: self._sums[c] / n if (n := self._counts[c]) else np.nan for c in self._sums}

    def finish(self, timings: dict) -> None:
        """Write the metadata of :func:`signatelec.io.write_result` with the footers and close."""
        from signatelec.io import schema_with_metadata

        meta = {"scene": self.scene.to_dict(), "timings": timings}
        for name, writer in self._writers.items():
            schema = schema_with_metadata(self._schemas[name], meta)
            serialized = schema.serialize().to_pybytes()
            entries = {k.decode(): v.decode() for k, v in schema.metadata.items()}
            entries["ARROW:schema"] = base64.b64encode(serialized).decode("ascii")
            writer.add_key_value_metadata(entries)
            writer.close()
        self._writers.clear()

    def close(self) -> None:
        """Close the files without metadata (a run that failed: they are thrown away)."""
        for writer in self._writers.values():
            writer.close()
        self._writers.clear()


# --- numpy columns to Arrow, as pyarrow converts the DataFrame ----------------------------------

#: numpy dtypes written directly: their pandas_type in the pandas metadata.
_PANDAS_TYPES = {"float64": "float64", "int32": "int32", "int64": "int64", "bool": "bool"}


def _frame(table) -> pd.DataFrame:
    """A block as a DataFrame (the lubricated columns are computed on DataFrames)."""
    from signatelec.engines.results import to_frame

    if hasattr(table, "iloc"):
        return table
    if hasattr(table, "to_pandas"):
        return table.to_pandas()
    return to_frame(table)


def arrow_table(columns) -> pa.Table:
    """The Arrow table of a block given as numpy columns by name (``phase`` as codes): what
    ``pa.Table.from_pandas(to_frame(columns), preserve_index=False)`` gives, schema and pandas
    metadata included (tests/test_streaming.py compares them), built without pandas. A
    DataFrame, or columns of another type, go through pandas; an Arrow table is returned as is."""
    import pyarrow as pa

    if isinstance(columns, pa.Table):
        return columns
    direct = not hasattr(columns, "iloc") and all(
        isinstance(values, np.ndarray)
        and (values.dtype.kind in "iu" if name == "phase" else values.dtype.name in _PANDAS_TYPES)
        for name, values in columns.items()
    )
    if not direct:
        return pa.Table.from_pandas(_frame(columns), preserve_index=False)
    arrays, described = [], []
    for name, values in columns.items():
        if name == "phase":
            codes = _numpy_array(pa, np.asarray(values, dtype=np.int8))
            arrays.append(pa.DictionaryArray.from_arrays(codes, _string_array(pa, PHASES)))
            meta = {"num_categories": len(PHASES), "ordered": False}
            described.append((name, "categorical", "int8", meta))
        else:
            values = np.asarray(values)
            arrays.append(_numpy_array(pa, values))
            dtype = values.dtype.name
            described.append((name, _PANDAS_TYPES[dtype], dtype, None))
    schema = pa.schema(
        [pa.field(name, array.type) for name, array in zip(columns, arrays, strict=True)],
        metadata={b"pandas": pandas_metadata(described)},
    )
    return pa.Table.from_arrays(arrays, schema=schema)


# pa.array() would import pandas (to ask whether its argument is a pandas object): the arrays are
# made from their buffers, which Arrow's columnar format defines (no validity bitmap: no nulls).


def _numpy_array(pa, values: np.ndarray):
    """An Arrow array of a 1-D numpy array of numbers or booleans (bit-packed); NaN is null,
    as pandas' missing value becomes in ``from_pandas``."""
    if values.dtype == np.bool_:
        bits = np.packbits(values, bitorder="little")
        return pa.Array.from_buffers(pa.bool_(), len(values), [None, pa.py_buffer(bits)])
    values = np.ascontiguousarray(values)
    validity, nulls = None, 0
    if values.dtype.kind == "f":
        valid = ~np.isnan(values)
        nulls = len(values) - int(np.count_nonzero(valid))
        if nulls:
            validity = pa.py_buffer(np.packbits(valid, bitorder="little"))
    kind = pa.from_numpy_dtype(values.dtype)
    return pa.Array.from_buffers(
        kind, len(values), [validity, pa.py_buffer(values)], null_count=nulls
    )


#: Arrow types read back as numpy without pandas (:func:`arrow_numbers`).
_NUMPY_TYPES = {"double": np.float64, "int32": np.int32, "int64": np.int64}


def arrow_numbers(column) -> np.ndarray | None:
    """A numeric Arrow column as numpy (nulls as NaN), None for another type. Its buffers are
    read directly: ``to_numpy`` would import pandas."""
    dtype = _NUMPY_TYPES.get(str(column.type))
    if dtype is None:
        return None
    parts = []
    for chunk in column.chunks:
        validity, data = chunk.buffers()[:2]
        values = np.frombuffer(data, dtype=dtype)[chunk.offset : chunk.offset + len(chunk)]
        if chunk.null_count:
            bits = np.unpackbits(np.frombuffer(validity, np.uint8), bitorder="little")
            valid = bits[chunk.offset : chunk.offset + len(chunk)].astype(bool)
            values = np.where(valid, values.astype(float), np.nan)
        parts.append(values)
    return np.concatenate(parts) if len(parts) != 1 else parts[0]


def _string_array(pa, texts) -> object:
    data = [t.encode("utf-8") for t in texts]
    offsets = np.cumsum([0, *(len(d) for d in data)], dtype=np.int32)
    buffers = [None, pa.py_buffer(offsets), pa.py_buffer(b"".join(data))]
    return pa.Array.from_buffers(pa.string(), len(data), buffers)


def pandas_metadata(columns: list[tuple]) -> bytes:
    """The ``pandas`` schema metadata pyarrow writes for a DataFrame without index whose columns
    are ``(name, pandas_type, numpy_type, metadata)``."""
    import pyarrow as pa

    entries = [
        {"name": n, "field_name": n, "pandas_type": p, "numpy_type": t, "metadata": m}
        for n, p, t, m in columns
    ]
    meta = {
        "index_columns": [],
        "column_indexes": [],
        "columns": entries,
        "attributes": {},
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": _pandas_version(),
    }
    return json.dumps(meta).encode("utf-8")


def _pandas_version() -> str:
    """pandas' version without importing pandas: the name of its installed distribution's
    metadata directory (importlib.metadata's answer, without scanning the whole path)."""
    import sys

    if "pandas" in sys.modules:
        return sys.modules["pandas"].__version__
    spec = importlib.util.find_spec("pandas")
    if spec is not None and spec.submodule_search_locations:
        site = os.path.dirname(spec.submodule_search_locations[0])
        found = glob.glob(os.path.join(glob.escape(site), "pandas-*.dist-info"))
        if len(found) == 1:
            return os.path.basename(found[0])[len("pandas-") : -len(".dist-info")]
    from importlib.metadata import version

    return version("pandas")
