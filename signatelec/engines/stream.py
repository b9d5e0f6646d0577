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
"""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.config.scene import Scene

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

    def write(self, balls: pd.DataFrame, signals: pd.DataFrame) -> None:
        """Append one block (the rows of its recorded instants, in time order)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        if self.scene.effects.lubrication != "none":
            # the lubricated columns are post-processing of each block's kinematics and loads
            from signatelec.engines.lubrication import lubricate_tables

            lubricate_tables(self.scene, balls, signals)
        for name, df in (("balls", balls), ("signals", signals)):
            table = pa.Table.from_pandas(df, preserve_index=False)
            writer = self._writers.get(name)
            if writer is None:
                # the Arrow schema is stored with the metadata at the end (finish)
                path = self.directory / f"{name}.parquet"
                writer = pq.ParquetWriter(path, table.schema, store_schema=False)
                self._writers[name] = writer
                self._schemas[name] = table.schema
            writer.write_table(table)
        self.n_instants += len(signals)
        steady = signals[signals["time_s"] > self.scene.setup_time_s + 1e-12]
        for column in steady.columns:
            values = steady[column]
            if column == "phase" or not np.issubdtype(values.dtype, np.number):
                continue
            values = values.to_numpy(dtype=float)
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
