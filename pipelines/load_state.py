"""Load-state estimation from a resistance trace: generate, features, train, evaluate, report.

Usage::

    python pipelines/load_state.py [--out OUT] [--report DIR] [--quick] [--reuse] [--ship]

Runs :func:`signatelec.studies.load_state.run_study` (its docstring lists the steps): the runs
of ``datasets/load_state.toml`` and the windows measured from them go to OUT (default
``out/load_state``; generation resumes where it stopped), the report (``load_state.md``,
``load_state.png``, the metrics and signature-twin tables, ``benchmark.json``: the time to
estimate a 1 s trace at 50 kHz, model loaded) to DIR (default ``docs/load_state``).

About 30 min on one core from scratch, 6 min with ``--reuse`` (skips generation and features
when OUT holds the feature tables). ``--ship`` also writes the default model's training table
``signatelec/estimation/data/load_state_features.parquet``
(:func:`signatelec.estimation.training.shipped_table`: one 50 ms and one other window per
training run, the model's features as float32) and the example trace
``datasets/example_trace.csv``. ``--quick`` (a pipeline check, ~30 s): 24 training and 6 test
runs of 0.1 s, 2 folds. ``--ship-paper`` (alone: no study) generates the paper-fidelity runs of
``datasets/load_state_paper.toml`` into OUT/runs_paper and of
``datasets/load_state_paper_boundary.toml`` and ``datasets/load_state_paper_fold.toml`` into
OUT/runs_<dataset name> (~0.4 s of CPU per run, 16 min for the 2400) and writes the default
model's second table ``signatelec/estimation/data/load_state_paper_features.parquet``
(:func:`signatelec.studies.load_state.paper_table`), and its stretch model's table
``signatelec/estimation/data/load_state_stretch_features.parquet``
(:func:`signatelec.studies.load_state.stretch_table`, ~4 min more); the study's default-model
figures read them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from signatelec.estimation.training import DEFAULT_TABLE, PAPER_TABLE, STRETCH_TABLE
from signatelec.studies.load_state import run_study, ship_paper_table

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "datasets" / "load_state.toml"
#: The paper-fidelity training runs: the design of the fast runs, then runs placed near the
#: regime boundaries and where the signature folds (docs/monitor/model_error.md).
PAPER_SPECS = [
    ROOT / "datasets" / "load_state_paper.toml",
    ROOT / "datasets" / "load_state_paper_boundary.toml",
    ROOT / "datasets" / "load_state_paper_fold.toml",
]
DEFAULT_OUT = ROOT / "out" / "load_state"
DEFAULT_REPORT = ROOT / "docs" / "load_state"
EXAMPLE_TRACE = ROOT / "datasets" / "example_trace.csv"


def main(argv: list[str] | None = None) -> dict:
    """Parse the arguments, run the study; returns its metrics table and benchmark."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(DEFAULT_OUT), help="work directory")
    parser.add_argument("--report", default=str(DEFAULT_REPORT), help="report directory")
    parser.add_argument("--quick", action="store_true", help="a small pipeline check")
    parser.add_argument("--ship", action="store_true", help="write the shipped table and example")
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="reuse the feature tables already in OUT (skip generation and features)",
    )
    parser.add_argument(
        "--ship-paper",
        action="store_true",
        help="only generate the paper-fidelity runs and write their shipped table",
    )
    args = parser.parse_args(argv)
    if args.ship_paper:
        log = lambda msg: print(msg, flush=True)  # noqa: E731
        table = ship_paper_table(Path(args.out), PAPER_SPECS, PAPER_TABLE, STRETCH_TABLE, log)
        return {"paper_table": table, "stretch_table": STRETCH_TABLE}
    return run_study(
        args.out,
        args.report,
        SPEC,
        quick=args.quick,
        reuse=args.reuse,
        ship_to=DEFAULT_TABLE if args.ship else None,
        example_to=EXAMPLE_TRACE if args.ship else None,
        log=lambda msg: print(msg, flush=True),
    )


if __name__ == "__main__":
    main()
