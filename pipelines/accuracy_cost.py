"""What accuracy costs in time: the fidelity ladder against a dt = 1e-8 s reference.

Usage::

    python pipelines/accuracy_cost.py [--out OUT_DIR] [--quick] [--fresh] [--quiet]
    signatelec study accuracy-cost --out OUT_DIR [--quick] [--fresh]   # the same, installed

Default OUT_DIR: docs/accuracy_cost. Five scenes (0.1 and 0.4 C_r at zero clearance; 0.2 C_r
with a 10 um preload, zero clearance and a 40 um clearance), each simulated by a reference
(velocity Verlet, dt = 1e-8 s, every seed effect) and by every setting of the ladder: the
quasi-static tier, dt from 2e-8 s to the stability limit, symplectic Euler, the linear and
Harris laws, no gravity, cage-mass scaling and the presets of signatelec.engines.fidelity. Writes
``accuracy_cost.parquet`` (one row per scene and setting), ``accuracy_cost.md`` (tables, and the
study's run time) and ``accuracy_cost.png`` (Pareto plot); ``--quick`` runs one scene, three
settings and three ball-pass periods. Finished cases are cached in OUT_DIR/.cache, so an
interrupted run resumes (``--fresh`` starts over). The work is done by
:mod:`signatelec.studies.accuracy_cost`, so the command works from an installed package too.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from signatelec.studies.accuracy_cost import run_study

DEFAULT_OUT = Path(__file__).resolve().parents[1] / "docs" / "accuracy_cost"


def main(argv: list[str] | None = None) -> dict[str, Path]:
    """Parse the arguments, run the study, return the paths of the three outputs."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(DEFAULT_OUT), help="output directory")
    parser.add_argument("--quick", action="store_true", help="one scene, three settings")
    parser.add_argument("--fresh", action="store_true", help="ignore cached finished cases")
    parser.add_argument("--quiet", action="store_true", help="no progress bar or file list")
    args = parser.parse_args(argv)
    return run_study(
        args.out,
        quick=args.quick,
        progress=not args.quiet,
        fresh=args.fresh,
        log=None if args.quiet else print,
    )


if __name__ == "__main__":
    main()
