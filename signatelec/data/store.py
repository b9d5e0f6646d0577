"""A dataset on disk: one Parquet part per trace, the spec and the manifest, resumable.

Layout: ``DIR/regime=<preload|zero|clearance>/trace-<id>.parquet``, one row per trace (labels
and the signals as list columns), each written under a temporary name and renamed; ``DIR`` is a
hive-partitioned dataset that pandas, pyarrow and dask read as is. ``DIR/_spec.json`` holds the
spec (written before the first trace), ``DIR/_manifest.json`` the summary (written last),
``DIR/.signatelec.json`` marks the directory as ``generate``'s (:mod:`signatelec.io`). The
trace ids done are those of the part files present: a rerun skips them, so a job killed at any
point resumes where it stopped. A rerun touches only what a job writes: it removes the
temporaries of dead jobs (:func:`signatelec.io.remove_stale_temporaries`) and moves a part file
that cannot be read aside (``regime=R/_trace-<id>.parquet.corrupt``, which readers skip) to
generate it again.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from signatelec import io
from signatelec._version import __version__
from signatelec.data.design import SEEDING, trace_seed_json
from signatelec.data.runner import STATUS_OK
from signatelec.data.spec import Spec

PART_GLOB = "regime=*/trace-*.parquet"
_PART_NAME = re.compile(r"^trace-(\d+)\.parquet$")
SPEC_FILE = "_spec.json"
MANIFEST_FILE = "_manifest.json"
LOCK_FILE = ".lock"
COMMAND = "generate"
#: Temporaries of earlier versions: ``.<file>.<pid>.tmp`` beside the file.
_LEGACY_TEMPORARY = re.compile(
    r"^\.(?:trace-[0-9]{6}\.parquet|_spec\.json|_manifest\.json)\.(?P<pid>[0-9]{1,10})\.tmp$"
)
#: A part file moved aside: ``_trace-<id>.parquet.corrupt[.<n>]`` (``_``: readers skip it).
QUARANTINE_SUFFIX = ".corrupt"


class DatasetDirError(OSError):
    """The output directory cannot hold this dataset (another spec, not a dataset, in use)."""


def _schema():
    """Columns of a part file (the regime is the partition directory) and their Arrow types."""
    import pyarrow as pa

    f64, i64, s = pa.float64(), pa.int64(), pa.string()
    return pa.schema(
        [
            ("trace_id", i64),
            ("design", pa.int32()),
            ("seed", i64),
            ("status", s),
            ("error", s),
            ("warnings", s),
            ("radial_load_n", f64),
            ("radial_load_fraction", f64),
            ("clearance_m", f64),
            ("epsilon", f64),
            ("epsilon_target", f64),
            ("omega_rad_s", f64),
            ("initial_ball_angle_rad", f64),
            ("fidelity", s),
            ("dt_s", f64),
            ("integrator", s),
            ("simulation_rate_hz", f64),
            ("sample_rate_hz", f64),
            ("duration_s", f64),
            ("t0_s", f64),
            ("n_samples", pa.int32()),
            ("noise_fraction", f64),
            ("drift_fraction", f64),
            ("offset_ohm", f64),
            ("quantisation_ohm", f64),
            ("resistance_mean_ohm", f64),
            ("delta_r_m", f64),
            ("max_ball_load_n", f64),
            ("ball_pass_frequency_hz", f64),
            ("cpu_s", f64),
            ("condition", s),
            ("spall_length_m", f64),
            ("spall_depth_m", f64),
            ("spall_angle_rad", f64),
            ("unbalance_force_n", f64),
            ("resistance_ohm", pa.list_(f64)),
            ("resistance_clean_ohm", pa.list_(f64)),
            ("signal", s),
            ("capacitance_f", pa.list_(f64)),
            ("capacitance_clean_f", pa.list_(f64)),
            ("impedance_ohm", pa.list_(f64)),
            ("impedance_clean_ohm", pa.list_(f64)),
        ]
    )


def part_path(out: Path, regime: str, trace_id: int) -> Path:
    return out / f"regime={regime}" / f"trace-{trace_id:06d}.parquet"


def done_trace_ids(out: str | Path) -> dict[int, Path]:
    """The manifest of finished traces: trace id -> part file, from the files present."""
    done: dict[int, Path] = {}
    for p in sorted(Path(out).glob(PART_GLOB)):
        match = _PART_NAME.match(p.name)
        if match:
            tid = int(match[1])
            if tid in done:
                raise DatasetDirError(f"trace {tid} is in both {done[tid]} and {p}")
            done[tid] = p
    return done


def part_metadata(spec: Spec, trace_id: int | None = None) -> dict:
    """The schema metadata of a part file (``trace_seed`` filled in when trace_id is given)."""
    meta = {
        "version": __version__,
        "spec": spec.to_dict(),
        "root_seed": spec.seed,
        "seeding": SEEDING,
    }
    if trace_id is not None:
        meta["trace_seed"] = trace_seed_json(spec.seed, trace_id)
    return meta


def record_table(rec: dict, metadata: dict):
    """A one-row Arrow table of a trace record, with the signatelec schema metadata."""
    import pyarrow as pa

    from signatelec.io import METADATA_KEY

    schema = _schema()
    arrays = []
    for fld in schema:
        value = rec[fld.name]
        if pa.types.is_list(fld.type):
            arrays.append(pa.array([np.asarray(value, dtype=float)], type=fld.type))
        else:
            arrays.append(pa.array([value], type=fld.type))
    meta = {METADATA_KEY: json.dumps(metadata).encode()}
    return pa.Table.from_arrays(arrays, schema=schema.with_metadata(meta))


def write_part(out: Path, rec: dict, metadata: dict) -> Path:
    """Write a trace's part file atomically (temporary name, fsync, rename); ``metadata``: the
    dataset's (:func:`part_metadata`), to which the trace's seed is added."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    meta = {**metadata, "trace_seed": trace_seed_json(rec["seed"], rec["trace_id"])}
    path = part_path(out, rec["regime"], rec["trace_id"])
    path.parent.mkdir(parents=True, exist_ok=True)
    sink = pa.BufferOutputStream()
    pq.write_table(record_table(rec, meta), sink)
    io.write_bytes_atomic(path, sink.getvalue().to_pybytes())
    return path


def remove_stale_temporaries(out: Path) -> list[str]:
    """Temporaries of dead jobs (never renamed into place), in ``out`` and its partitions; a
    live job's and every other file are left alone."""
    removed = io.remove_stale_temporaries(out, _LEGACY_TEMPORARY)
    for regime in out.glob("regime=*"):
        if regime.is_dir():
            removed += io.remove_stale_temporaries(regime, _LEGACY_TEMPORARY)
    return removed


def part_problem(path: Path, trace_id: int) -> str | None:
    """Why a part file cannot be the trace's record (None: it can): its footer and the id and
    status columns are read, so a truncated or foreign file is found without reading signals."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path, columns=["trace_id", "status"])
    except (OSError, ValueError, pa.ArrowException) as exc:
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return text if len(text) < 100 else text[:97] + "..."
    if table.num_rows != 1:
        return f"{table.num_rows} rows, a part file has one"
    if table.column("trace_id")[0].as_py() != trace_id:
        return f"holds trace {table.column('trace_id')[0].as_py()}"
    return None


def quarantine(path: Path) -> Path:
    """Move a part file aside under a name readers skip; returns the new path."""
    target = path.with_name(f"_{path.name}{QUARANTINE_SUFFIX}")
    n = 1
    while target.exists():
        n += 1
        target = path.with_name(f"_{path.name}{QUARANTINE_SUFFIX}.{n}")
    os.rename(path, target)
    return target


def verified_parts(
    out: Path, done: dict[int, Path], log: Callable[[str], None] | None = None
) -> dict[int, Path]:
    """The finished traces whose part files can be read; the others are quarantined (one line
    each to ``log``) and so generated again."""
    good = {}
    for trace_id, path in done.items():
        problem = part_problem(path, trace_id)
        if problem is None:
            good[trace_id] = path
            continue
        moved = quarantine(path)
        if log is not None:
            log(
                f"{path.relative_to(out)} cannot be read ({problem}); moved to "
                f"{moved.relative_to(out)}, trace {trace_id} is generated again"
            )
    return good


@contextlib.contextmanager
def locked(out: Path) -> Iterator[None]:
    """Hold ``out``'s lock file: one ``signatelec generate`` writes there at a time."""
    import fcntl

    with open(out / LOCK_FILE, "a") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise DatasetDirError(
                f"--out {str(out)!r}: another signatelec generate is writing there"
            ) from None
        yield


def is_dataset(directory: Path) -> bool:
    """A dataset directory written before the marker existed (it has the spec file)."""
    return (directory / SPEC_FILE).is_file()


def prepare_output(spec: Spec, out: str | Path) -> Path:
    """Create ``out`` or check that it holds this spec's (partial) dataset; a new dataset gets
    its marker and spec file. Raises :class:`DatasetDirError` (nothing written) otherwise."""
    out = Path(out)
    spec_path = out / SPEC_FILE
    where = f"--out {str(out)!r}"
    if out.exists():
        if not out.is_dir():
            raise DatasetDirError(f"{where}: exists and is not a directory")
        if is_dataset(out):
            why = io.refusal(out, COMMAND)
            if why is not None and io.read_marker(out) is not None:
                raise DatasetDirError(f"{where}: {why}")
            try:
                stored = json.loads(spec_path.read_text(encoding="utf-8"))["spec"]
            except (OSError, ValueError, KeyError):
                stored = None
            if stored != json.loads(spec.to_json()):
                raise DatasetDirError(
                    f"{where}: holds a dataset of another spec; choose another "
                    "directory (or remove it) to generate this one"
                )
            if io.read_marker(out) is None:  # a dataset of a version before the marker
                with contextlib.suppress(OSError):
                    io.write_marker(out, COMMAND)
            return out
        why = io.refusal(out, COMMAND, ignore=(LOCK_FILE,))
        if why is not None:
            raise DatasetDirError(f"{where}: {why}")
    created = out.absolute()
    while not created.parent.exists():  # the first directory this call creates, if any
        created = created.parent
    created = None if created.exists() else created
    try:
        out.mkdir(parents=True, exist_ok=True)
        io.write_marker(out, COMMAND)
        io.write_json_atomic(
            spec_path,
            {"version": __version__, "n_traces": spec.n_traces, "spec": json.loads(spec.to_json())},
        )
    except OSError as exc:
        if created is not None:
            shutil.rmtree(created, ignore_errors=True)
        else:
            for name in (io.MARKER_FILE, SPEC_FILE):
                with contextlib.suppress(OSError):
                    (out / name).unlink()
        if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EIO):  # not refused: rerun later
            raise
        raise DatasetDirError(
            f"{where}: cannot write there ({exc.strerror or exc}); nothing was written"
        ) from None
    return out


def write_manifest(spec: Spec, out: Path) -> dict:
    """``_manifest.json`` from the part files present (written atomically, last)."""
    import pyarrow.dataset as pads

    done = done_trace_ids(out)
    failed: list[int] = []
    regimes: dict[str, int] = {}
    if done:
        table = pads.dataset(
            [str(p) for p in done.values()], format="parquet", partitioning=None
        ).to_table(columns=["trace_id", "status"])
        ids = table.column("trace_id").to_pylist()
        status = table.column("status").to_pylist()
        failed = sorted(i for i, s in zip(ids, status, strict=True) if s != STATUS_OK)
        for p in done.values():
            regime = p.parent.name.split("=", 1)[1]
            regimes[regime] = regimes.get(regime, 0) + 1
    expected = set(range(spec.n_traces))
    manifest = {
        "version": __version__,
        "name": spec.name,
        "n_traces": spec.n_traces,
        "complete": set(done) == expected,
        "done": len(done),
        "failed": failed,
        "regimes": dict(sorted(regimes.items())),
        "missing": sorted(expected - set(done)),
        "layout": "regime=<regime>/trace-<id>.parquet, one row per trace, signals as list columns",
    }
    io.write_json_atomic(out / MANIFEST_FILE, manifest)
    return manifest


def read_dataset(out: str | Path, columns: list[str] | None = None, regimes=None):
    """The dataset as a pandas DataFrame sorted by trace_id (``regimes``: a subset)."""
    import pandas as pd

    filters = [("regime", "in", list(regimes))] if regimes else None
    df = pd.read_parquet(out, columns=columns, filters=filters)
    if "trace_id" in df:
        df = df.sort_values("trace_id", ignore_index=True)
    return df
