"""A dataset on disk: one Parquet part per trace, the spec and the manifest, resumable.

Layout: ``DIR/regime=<preload|zero|clearance>/trace-<id>.parquet``, one row per trace (labels
and the signals as list columns), each written under a temporary name and renamed; ``DIR`` is a
hive-partitioned dataset that pandas, pyarrow and dask read as is. ``DIR/_spec.json`` holds the
spec (written before the first trace), ``DIR/_manifest.json`` the summary (written last). The
trace ids done are those of the part files present: a rerun skips them, so a job killed at any
point resumes where it stopped.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from signatelec._version import __version__
from signatelec.data.design import SEEDING, trace_seed_json
from signatelec.data.runner import STATUS_OK
from signatelec.data.spec import Spec

PART_GLOB = "regime=*/trace-*.parquet"
_PART_NAME = re.compile(r"^trace-(\d+)\.parquet$")
SPEC_FILE = "_spec.json"
MANIFEST_FILE = "_manifest.json"
LOCK_FILE = ".lock"


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
            ("resistance_ohm", pa.list_(f64)),
            ("resistance_clean_ohm", pa.list_(f64)),
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
    import pyarrow.parquet as pq

    meta = {**metadata, "trace_seed": trace_seed_json(rec["seed"], rec["trace_id"])}
    path = part_path(out, rec["regime"], rec["trace_id"])
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            pq.write_table(record_table(rec, meta), fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def remove_stale_temporaries(out: Path) -> None:
    """Temporary files of a killed job (never renamed into place)."""
    for pattern in (".*.tmp", "regime=*/.*.tmp"):
        for p in out.glob(pattern):
            with contextlib.suppress(OSError):
                p.unlink()


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


def prepare_output(spec: Spec, out: str | Path) -> Path:
    """Create ``out`` or check that it holds this spec's (partial) dataset."""
    out = Path(out)
    spec_path = out / SPEC_FILE
    if out.exists():
        if not out.is_dir():
            raise DatasetDirError(f"--out {str(out)!r}: exists and is not a directory")
        if spec_path.exists():
            try:
                stored = json.loads(spec_path.read_text(encoding="utf-8"))["spec"]
            except (OSError, ValueError, KeyError):
                stored = None
            if stored != json.loads(spec.to_json()):
                raise DatasetDirError(
                    f"--out {str(out)!r}: holds a dataset of another spec; choose another "
                    "directory (or remove it) to generate this one"
                )
            return out
        if any(not p.name.startswith(".") for p in out.iterdir()):  # .lock, temporaries
            raise DatasetDirError(
                f"--out {str(out)!r}: is not empty and holds no signatelec dataset; choose an "
                "empty or new directory"
            )
    out.mkdir(parents=True, exist_ok=True)
    _write_json(
        spec_path,
        {"version": __version__, "n_traces": spec.n_traces, "spec": json.loads(spec.to_json())},
    )
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
    _write_json(out / MANIFEST_FILE, manifest)
    return manifest


def read_dataset(out: str | Path, columns: list[str] | None = None, regimes=None):
    """The dataset as a pandas DataFrame sorted by trace_id (``regimes``: a subset)."""
    import pandas as pd

    filters = [("regime", "in", list(regimes))] if regimes else None
    df = pd.read_parquet(out, columns=columns, filters=filters)
    if "trace_id" in df:
        df = df.sort_values("trace_id", ignore_index=True)
    return df
