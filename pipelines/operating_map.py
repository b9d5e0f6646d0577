"""The operating map: every catalogue bearing at its rated speeds, with nothing but defaults.

Usage::

    python pipelines/operating_map.py [--out OUT_DIR] [--quick] [--cage balls] [--fresh]
    signatelec study operating-map --out OUT_DIR [--quick] [--cage balls]   # the same, installed

Both cage models (``balls`` and ``rigid``) unless ``--cage`` names some.

Default OUT_DIR: docs/operating_map. Writes ``operating_map.parquet`` (one row per cell),
``operating_map.md`` and ``operating_map.png``, and ``below_minimum_load.{md,parquet}`` (the
cells at F_r = 0 found in the cache); the work is done by :mod:`signatelec.studies.operating_map`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from signatelec.studies.operating_map import CAGES, run_study

DEFAULT_OUT = Path(__file__).resolve().parents[1] / "docs" / "operating_map"


def main(argv: list[str] | None = None) -> dict[str, Path]:
    """Parse the arguments, run the map, return the paths of its outputs."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(DEFAULT_OUT), help="output directory")
    parser.add_argument("--quick", action="store_true", help="three cells, two ball passes")
    parser.add_argument(
        "--cage", action="append", help="cage model (repeatable; default: balls and rigid)"
    )
    parser.add_argument("--fresh", action="store_true", help="ignore cached finished cells")
    parser.add_argument("--quiet", action="store_true", help="no progress")
    args = parser.parse_args(argv)
    return run_study(
        args.out,
        quick=args.quick,
        cages=tuple(args.cage or CAGES),
        fresh=args.fresh,
        log=None if args.quiet else print,
    )


if __name__ == "__main__":
    main()
