"""``signatelec estimate`` and ``signatelec train``: the load state from a trace."""

from __future__ import annotations

from pathlib import Path

import click

from signatelec.cli.common import (
    InputError,
    check_writable_file,
    cli,
)


@cli.command()
@click.argument("trace_file", metavar="TRACE", type=str)
@click.option("--omega", "omega_rad_s", type=float, required=True, help="Inner-ring speed, rad/s.")
@click.option(
    "--model",
    "model_path",
    type=str,
    default=None,
    help="Model file from `signatelec train` (default: the model built from the shipped "
    "training table, on first use).",
)
@click.option("--out", "out", type=str, default=None, help="Write the estimate: .json or .parquet.")
@click.option("--time-column", default="time_s", show_default=True, help="Time column (s).")
@click.option(
    "--resistance-column",
    default="resistance_ohm",
    show_default=True,
    help="Resistance column (ohm).",
)
@click.option("--quiet", is_flag=True, help="No summary.")
def estimate(trace_file, omega_rad_s, model_path, out, time_column, resistance_column, quiet):
    """Estimate F_r, epsilon, clearance and regime from a resistance trace (CSV or Parquet).

    The trace needs at least 5 ball passes; isolated missing samples, small gaps and uneven
    sampling are repaired and a set-up transient is cut off; a trace whose ball-pass ripple is
    not at the frequency --omega predicts, whose level is outside the model's range or whose
    features are unlike its training traces is refused (exit 2).
    """
    from signatelec.estimation.domain import DomainError
    from signatelec.estimation.estimate import estimate as run_estimate
    from signatelec.estimation.persistence import ModelError, default_model, load_model
    from signatelec.estimation.report import format_estimate
    from signatelec.estimation.report import write_result as write_estimate
    from signatelec.measurement.traces import TraceError, prepare_trace, read_trace

    if out is not None:
        check_writable_file(out, suffixes=(".json", ".parquet"))
    from signatelec.io import TRACE_MAX_BYTES, input_size_problem

    problem = input_size_problem(trace_file, TRACE_MAX_BYTES)
    if problem:
        raise InputError(f"trace {trace_file!r}: {problem}")
    try:
        t, r, phase = read_trace(trace_file, time_column, resistance_column)
        trace = prepare_trace(t, r, omega_rad_s, source=f"trace {trace_file!r}", phase=phase)
    except TraceError as exc:
        raise InputError(str(exc)) from None
    try:
        if model_path:
            model = load_model(model_path)
        else:
            model = default_model(log=lambda m: click.echo(f"signatelec: {m}", err=True))
    except ModelError as exc:
        raise InputError(str(exc)) from None
    try:
        result = run_estimate(trace, omega_rad_s, model)
    except (TraceError, DomainError) as exc:
        raise InputError(str(exc)) from None
    if out is not None:
        try:
            write_estimate(result, out)
        except OSError as exc:
            raise InputError(f"--out {out!r}: cannot write there ({exc.strerror or exc})") from None
    if not quiet:
        click.echo(format_estimate(result))
        if out is not None:
            click.echo(f"wrote {out}")


@cli.command()
@click.argument("dataset", metavar="DATASET", type=str)
@click.option("--out", "out", type=str, required=True, help="Model file to write.")
@click.option("--quiet", is_flag=True, help="No summary.")
def train(dataset, out, quiet):
    """Train the load-state estimator on DATASET and write the model file.

    DATASET: a directory written by `signatelec generate` (each measured trace gives one row of
    features; traces whose ball-pass ripple contradicts their speed label, or whose level is
    not steady, are skipped) or a Parquet feature table with labels (pipelines/load_state.py
    writes one). The model stores its training domain: the level range and what the in-domain
    score of `signatelec estimate` compares with.
    """
    from signatelec.estimation.persistence import save_model
    from signatelec.estimation.training import features_from_dataset, train_model

    check_writable_file(out)
    where = f"dataset {dataset!r}"
    if not Path(dataset).exists():
        raise InputError(f"{where}: no such file or directory")
    try:
        table = features_from_dataset(dataset)
    except (OSError, ValueError, KeyError) as exc:
        raise InputError(f"{where}: cannot be read as a dataset or feature table ({exc})") from None
    refused = table.attrs.get("refused", [])
    if refused and not quiet:
        click.echo(
            f"signatelec: skipped {len(refused)} traces the sanity layer refuses, e.g. "
            f"{refused[0]}",
            err=True,
        )
    if len(table) < 10:
        raise InputError(f"{where}: {len(table)} usable traces; training needs at least 10")
    try:
        model = train_model(table, source=str(dataset))
    except ValueError as exc:
        raise InputError(f"{where}: {exc}") from None
    try:
        save_model(model, out)
    except OSError as exc:
        raise InputError(f"--out {out!r}: cannot write there ({exc.strerror or exc})") from None
    if not quiet:
        info = model.info
        click.echo(
            f"trained on {info['n_rows']} traces of {info['n_runs']} runs "
            f"({', '.join(info['targets'])}) in {info['fit_s']:.1f} s; wrote {out}"
        )
