"""``signatelec study ...``: the accuracy-cost study, the operating map and the diagnosis study."""

from __future__ import annotations

import contextlib

import click

from signatelec.cli.common import (
    EXIT_INCOMPLETE,
    InputError,
    Stopped,
    claim_output,
    cli,
)


@contextlib.contextmanager
def study_output(out: str, name: str, own: tuple[str, ...], kept: str | None = None):
    """Run a study's body into DIR ``out``: claimed first (it may hold only the study's ``own``
    files), marked as the study's output when the body ends; a write error stops with one line
    (exit 75) that says where finished work is ``kept``, when it is."""
    from signatelec.io import holds_only, write_marker

    command = f"study {name}"
    previous = lambda d: holds_only(d, own, False)  # noqa: E731
    claim_output(out, command, previous=previous, replaced=False)
    try:
        yield
        write_marker(out, command)
    except OSError as exc:
        resume = f"; {kept}: rerun the same command to resume" if kept else ""
        raise Stopped(
            f"--out {out!r}: cannot write there ({exc.strerror or exc}){resume}", EXIT_INCOMPLETE
        ) from None


@cli.group()
def study() -> None:
    """Studies of the model (accuracy-cost, ...)."""


@study.command("accuracy-cost")
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option("--quick", is_flag=True, help="One scene, three settings: a pipeline check.")
@click.option("--fresh", is_flag=True, help="Ignore finished cases cached in DIR/.cache.")
@click.option(
    "--defects",
    is_flag=True,
    help="Also the quasi-static tier against the DEM on spalled scenes: "
    "DIR/accuracy_cost_defects.{parquet,md}.",
)
@click.option("--quiet", is_flag=True, help="No progress bar or file list.")
def accuracy_cost(out, quick, fresh, defects, quiet):
    """Fidelity ladder against a dt = 1e-8 s reference: DIR/accuracy_cost.{parquet,md,png}."""
    from signatelec.studies.accuracy_cost import run_study

    own = (
        "accuracy_cost.parquet",
        "accuracy_cost.md",
        "accuracy_cost.png",
        "accuracy_cost_defects.parquet",
        "accuracy_cost_defects.md",
        ".cache",
    )
    with study_output(out, "accuracy-cost", own, "finished cases are kept in DIR/.cache"):
        run_study(
            out,
            quick=quick,
            progress=not quiet,
            fresh=fresh,
            log=None if quiet else click.echo,
            defects=defects,
        )


@study.command("operating-map")
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option(
    "--quick", is_flag=True, help="Three cells per cage model, two ball passes: a pipeline check."
)
@click.option(
    "--cage",
    "cages",
    multiple=True,
    default=("balls", "rigid"),
    show_default=True,
    help="Cage model(s) to map (repeatable; see the scene's effects.cage).",
)
@click.option("--fresh", is_flag=True, help="Ignore finished cells cached in DIR/.cache.")
@click.option(
    "--cached-only",
    is_flag=True,
    help="Run no cell: write the map from the cells finished in DIR/.cache, the others 'not run'.",
)
@click.option("--quiet", is_flag=True, help="No progress or file list.")
def operating_map(out, quick, cages, fresh, cached_only, quiet):
    """Every catalogue bearing at its rated speeds with the defaults: DIR/operating_map.{parquet,
    md,png}."""
    from signatelec.config.options import OPTION_TABLE
    from signatelec.studies.operating_map import run_study

    option = OPTION_TABLE[("effects", "cage")]
    for cage in cages:
        if not option.accepts(cage):
            raise InputError(f"--cage {cage!r}: {option.rule}")

    own = ("operating_map.parquet", "operating_map.md", "operating_map.png", ".cache")
    own += ("below_minimum_load.parquet", "below_minimum_load.md")
    with study_output(out, "operating-map", own, "finished cells are kept in DIR/.cache"):
        paths = run_study(
            out,
            quick=quick,
            cages=cages,
            fresh=fresh,
            cached_only=cached_only,
            log=None if quiet else click.echo,
        )
    if not quiet:
        for path in paths.values():
            click.echo(f"wrote {path}")


@study.command("lubrication-regimes")
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option("--quick", is_flag=True, help="Four speeds, one load and temperature: a check.")
@click.option("--quiet", is_flag=True, help="No progress or file list.")
def lubrication_regimes(out, quick, quiet):
    """Lambda, |Z| and phase of the lubricated seed bearing over speed, load and oil temperature:
    DIR/lubrication_regimes.{parquet,md,png}."""
    from signatelec.studies.lubrication_regimes import run_study

    own = (
        "lubrication_regimes.parquet",
        "lubrication_regimes.md",
        "lubrication_regimes.png",
        "bode.png",
    )
    with study_output(out, "lubrication-regimes", own):
        paths = run_study(out, quick=quick, log=None if quiet else click.echo)
    if not quiet:
        for path in paths.values():
            click.echo(f"wrote {path}")


@study.command("monitor")
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option(
    "--bank",
    "bank_dir",
    type=str,
    default="/tmp/monitor-bank",
    show_default=True,
    help="Where the DEM runs of the bank are cached (and the records written for a while).",
)
@click.option("--quick", is_flag=True, help="Two short records and a 15 s throughput run.")
@click.option("--quiet", is_flag=True, help="No progress or file list.")
def monitor_study(out, bank_dir, quick, quiet):
    """Monitoring on long records assembled from paper-fidelity DEM runs, and its throughput
    and memory at 1, 10 and 60 minutes of 50 kHz trace: DIR/monitor.md, parquet tables, PNG."""
    from signatelec.studies.monitor import run_study

    own = (
        "monitor.md",
        "monitor_example.png",
        "monitor_stretches.parquet",
        "monitor_calibration.parquet",
        "monitor_changes.parquet",
        "monitor_throughput.parquet",
    )
    with study_output(out, "monitor", own, f"the DEM runs are kept in {bank_dir}"):
        paths = run_study(out, bank_dir, quick=quick, log=None if quiet else click.echo)
    if not quiet:
        for path in paths.values():
            click.echo(f"wrote {path}")


@study.command("diagnosis")
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option(
    "--quick",
    is_flag=True,
    help="Three training runs and one test run per condition and bearing, all at the fast "
    "preset: a pipeline check.",
)
@click.option("--fresh", is_flag=True, help="Measure the cached runs' features again.")
@click.option("--workers", type=int, default=0, show_default=True, help="Worker processes.")
@click.option("--quiet", is_flag=True, help="No progress or file list.")
def diagnosis(out, quick, fresh, workers, quiet):
    """Condition model on held-out paper-fidelity runs: DIR/diagnosis.{parquet,md,png} and
    DIR/signatures.png; the runs are cached in DIR/.cache (an interrupted study resumes)."""
    from pathlib import Path

    from signatelec.studies.diagnosis import DEFAULT_SPEC, run_study

    if workers < 0:
        raise InputError(f"--workers {workers}: must be >= 0")
    own = ("diagnosis.parquet", "diagnosis.md", "diagnosis.png", "signatures.png", ".cache")
    with study_output(out, "diagnosis", own, "finished runs are kept in DIR/.cache"):
        run_study(
            Path(out) / ".cache",
            Path(out),
            DEFAULT_SPEC,
            quick=quick,
            reuse=not fresh,
            workers=workers,
            log=(lambda m: None) if quiet else click.echo,
        )
    if not quiet:
        for name in own[:-1]:
            click.echo(f"wrote {Path(out) / name}")
