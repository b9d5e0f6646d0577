"""Regenerate the seed's figures 6-11 (Machado, Guessasma, Bellenger, section 4) as PNG.

Usage::

    python pipelines/paper_figures.py [OUT_DIR] [--quick]     # default OUT_DIR: docs/figures
    signatelec figures --out OUT_DIR [--quick]                 # the same, installed

Writes ``figure_6_9.png`` (force, current and potential around the bearing at epsilon = 0.5 and
0.3), ``figure_7_10.png`` (one ball's outer-raceway force over a rolling round, several F_r and
epsilon) and ``figure_8_11.png`` (bearing resistance against time, same cases). Seven DEM runs of
about 0.044 s of bearing time each; ``--quick`` stops them 2 ms after the set-up.
The work is done by :func:`signatelec.studies.paper_figures.paper_figures`, so the command
works from an installed package too.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from signatelec.studies.paper_figures import paper_figures

DEFAULT_OUT = Path(__file__).resolve().parents[1] / "docs" / "figures"


def main(out_dir: str | Path = DEFAULT_OUT, quick: bool = False, progress: bool = True):
    """Run the simulations and write the three PNGs into ``out_dir``; returns their paths."""
    paths = paper_figures(out_dir, quick=quick, progress=progress)
    for path in paths:
        print(f"wrote {path}")
    return paths


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", nargs="?", default=str(DEFAULT_OUT), help="output directory")
    parser.add_argument("--quick", action="store_true", help="short runs (pipeline check)")
    args = parser.parse_args()
    main(args.out_dir, quick=args.quick)
