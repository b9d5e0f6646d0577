"""The bearing's condition from a resistance trace: generate, features, train, evaluate, report.

Usage::

    nice -n 10 python pipelines/diagnosis.py [--out OUT] [--report DIR] [--quick] [--fresh]
                                             [--workers N] [--ship]

Runs :func:`signatelec.studies.diagnosis.run_study` (its docstring lists the steps): the runs of
``datasets/diagnosis.toml`` for the seed's bearing and the 6205, their held-out
paper-fidelity test runs and the 350 held-out healthy runs of the false-alarm bound go to OUT
(default ``out/diagnosis``; generation resumes where it stopped, the measured features are
reused unless ``--fresh``), the report (``diagnosis.md``,
``diagnosis.png``, ``diagnosis.parquet``, ``signatures.png``) to DIR (default
``docs/diagnosis``). ``signatelec study diagnosis --out DIR`` runs the same into one directory.
``--ship`` also writes the default condition model's training table
``signatelec/estimation/data/condition_features.parquet`` (one measured window per training
run, the condition model's features as float32) and its spall-length calibration table
``condition_calibration.parquet`` (the held-out calibration runs' windows).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from signatelec.estimation.training import CONDITION_TABLE
from signatelec.studies.diagnosis import DEFAULT_SPEC, run_study

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = ROOT / "out" / "diagnosis"
DEFAULT_REPORT = ROOT / "docs" / "diagnosis"


def main(argv: list[str] | None = None) -> dict:
    """Parse the arguments, run the study; returns its acceptance figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(DEFAULT_OUT), help="work directory")
    parser.add_argument("--report", default=str(DEFAULT_REPORT), help="report directory")
    parser.add_argument("--quick", action="store_true", help="a small pipeline check")
    parser.add_argument("--fresh", action="store_true", help="measure the features again")
    parser.add_argument("--workers", type=int, default=0, help="worker processes")
    parser.add_argument("--ship", action="store_true", help="write the shipped table")
    args = parser.parse_args(argv)
    return run_study(
        Path(args.out),
        Path(args.report),
        DEFAULT_SPEC,
        quick=args.quick,
        reuse=not args.fresh,
        workers=args.workers,
        ship_to=CONDITION_TABLE.parent if args.ship else None,
        log=lambda msg: print(msg, flush=True),
    )


if __name__ == "__main__":
    main()
