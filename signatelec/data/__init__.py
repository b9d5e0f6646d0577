"""Synthetic data: labelled resistance signatures at scale, written as Parquet.

``signatelec generate SPEC.toml --out DIR`` (or :func:`generate`) expands a dataset spec's
design into traces, simulates each trace's scene, applies the measurement model
(:mod:`signatelec.measurement.model`) and writes one small Parquet file per trace; the spec
format and the output schema are documented in ``datasets/README.md``.

Modules, by concern:

- :mod:`~signatelec.data.spec`: reading and checking a spec (rows of
  :mod:`signatelec.config.constraints`), its designs and what its traces share;
- :mod:`~signatelec.data.design`: grid, random and Latin-hypercube designs, the seeds, each
  trace's operating point (a target epsilon included);
- :mod:`~signatelec.data.runner`: one trace simulated and measured, the kernels warmed up;
- :mod:`~signatelec.data.store`: Parquet parts, spec and manifest files, resume, reading back;
- :mod:`~signatelec.data.schedule`: local worker processes or a Dask cluster.
"""

from signatelec.data.design import (
    LHS_KEY,
    OperatingPoint,
    TraceTask,
    design_traces,
    operating_point,
    trace_rng,
    trace_seed_sequence,
)
from signatelec.data.runner import (
    SIGNALS,
    STATUS_FAILED,
    STATUS_OK,
    EpsilonError,
    run_trace,
    warm_up,
)
from signatelec.data.schedule import Summary, generate
from signatelec.data.spec import (
    DesignBlock,
    Factor,
    Spec,
    SpecError,
    TraceContext,
    load_spec,
    spec_from_dict,
)
from signatelec.data.store import (
    MANIFEST_FILE,
    SPEC_FILE,
    DatasetDirError,
    done_trace_ids,
    read_dataset,
    write_manifest,
)

__all__ = [
    "LHS_KEY",
    "MANIFEST_FILE",
    "SIGNALS",
    "SPEC_FILE",
    "STATUS_FAILED",
    "STATUS_OK",
    "DatasetDirError",
    "DesignBlock",
    "EpsilonError",
    "Factor",
    "OperatingPoint",
    "Spec",
    "SpecError",
    "Summary",
    "TraceContext",
    "TraceTask",
    "design_traces",
    "done_trace_ids",
    "generate",
    "load_spec",
    "operating_point",
    "read_dataset",
    "run_trace",
    "spec_from_dict",
    "trace_rng",
    "trace_seed_sequence",
    "warm_up",
    "write_manifest",
]
