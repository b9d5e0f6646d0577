"""Files: Parquet tables with the scene in the schema metadata, written atomically; the cache.

Every output is written under a temporary name in the destination's parent and renamed when
complete, so a crash or an error never leaves a half-written file or directory behind.

What signatelec can rebuild (compiled kernels, fitted models) lives under :func:`cache_root`,
``$SIGNATELEC_CACHE_DIR`` or ``~/.cache/signatelec``, one subdirectory each (:func:`cache_dir`).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from signatelec._version import __version__

METADATA_KEY = b"signatelec"


class OutputError(OSError):
    """The output location cannot be written; the message names it."""


class CacheWarning(UserWarning):
    """The cache could not be used as it was; the one-line message says what was done instead."""


def cache_root() -> Path:
    """``$SIGNATELEC_CACHE_DIR``, else ``~/.cache/signatelec`` (not created)."""
    root = os.environ.get("SIGNATELEC_CACHE_DIR")
    return Path(root) if root else Path.home() / ".cache" / "signatelec"


_FALLBACK: dict[Path, Path] = {}


def cache_dir(name: str) -> Path:
    """``cache_root() / name``, created and writable; when it cannot be (read-only, a file in
    the way), a temporary directory used for the rest of the process, with one warning line."""
    wanted = cache_root() / name
    try:
        wanted.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=wanted, prefix=".probe-"):
            pass
        return wanted
    except OSError as exc:
        if wanted not in _FALLBACK:
            _FALLBACK[wanted] = Path(tempfile.mkdtemp(prefix=f"signatelec-{name}-"))
            warnings.warn(
                CacheWarning(
                    f"cache directory {str(wanted)!r} cannot be written "
                    f"({exc.strerror or exc}); using {_FALLBACK[wanted]} for this process"
                ),
                stacklevel=2,
            )
        return _FALLBACK[wanted]


def table_with_metadata(df: pd.DataFrame, metadata: dict) -> pa.Table:
    table = pa.Table.from_pandas(df, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta[METADATA_KEY] = json.dumps({"version": __version__, **metadata}).encode()
    return table.replace_schema_metadata(meta)


def read_metadata(path: str | Path) -> dict:
    """The signatelec metadata (scene, version, ...) stored in a Parquet file's schema."""
    meta = pq.read_schema(path).metadata or {}
    return json.loads(meta.get(METADATA_KEY, b"{}"))


@contextmanager
def atomic_directory(out_dir: str | Path) -> Iterator[Path]:
    """Yield a temporary directory that replaces ``out_dir`` only if the block succeeds.

    Files already in an existing ``out_dir`` but not rewritten are kept.
    """
    out = Path(out_dir)
    parent = out.parent if str(out.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=parent))
    except OSError as exc:
        raise OutputError(
            f"--out {str(out)!r}: cannot write there ({exc.strerror}); choose a writable directory"
        ) from None
    try:
        yield tmp
        if out.is_dir():
            for item in tmp.iterdir():
                os.replace(item, out / item.name)
            tmp.rmdir()
        else:
            os.replace(tmp, out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def write_result(result, out_dir: str | Path) -> None:
    """Write ``balls.parquet`` and ``signals.parquet`` of a simulation result."""
    meta = {"scene": result.scene.to_dict(), "timings": result.timings}
    with atomic_directory(out_dir) as tmp:
        for name in ("balls", "signals"):
            pq.write_table(
                table_with_metadata(getattr(result, name), meta), tmp / f"{name}.parquet"
            )


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` under a temporary name in its directory, then rename: a
    reader never sees a half-written file. OSError when the directory is not writable."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
