"""``signatelec estimate`` and ``signatelec train``: the load state from a trace."""

from __future__ import annotations

import gc
import re
from pathlib import Path

import click

from signatelec.cli.common import (
    InputError,
    check_writable_file,
    cli,
)
from signatelec.interrupts import signals_deferred

#: What a simulation's output refused as unlike the training traces lacks, when its file
#: tells it is one (a ``phase`` column) and its residual is unlike a meter's noise (the
#: farthest features name noise_kurtosis or noise_colour above the training traces'): a clean
#: DEM trace's residual is the ball set's own, spiky and coloured (kurtosis ~15, colour ~3,
#: where a meter's white noise gives ~3 and ~1).
SIMULATED = (
    "; a simulation's signals carry no meter's noise, which every training trace has: "
    "`signatelec generate` applies the measurement model (noise, drift, offset) to its traces"
)
NOISE_FREE = re.compile(r"noise_(kurtosis|colour) \S+ \(z \+")


def trace_columns(command):
    """The options naming a trace file's time and resistance columns."""
    command = click.option(
        "--resistance-column",
        default="resistance_ohm",
        show_default=True,
        help="Resistance column (ohm).",
    )(command)
    return click.option(
        "--time-column", default="time_s", show_default=True, help="Time column (s)."
    )(command)


def healthy_prior_option(command):
    """``--healthy-prior P``: the condition probabilities reported under a stated prior."""
    return click.option(
        "--healthy-prior",
        type=float,
        default=None,
        help="Probability that the bearing is healthy before the trace is read: the condition "
        "probabilities reported are under it, the calls the training mix's (default: the "
        "condition model's training mix).",
    )(command)


def bearing_option(command):
    """``--bearing DESIGNATION``: the catalogue bearing whose geometry places the lines."""
    return click.option(
        "--bearing",
        "designation",
        type=str,
        default=None,
        help="Catalogue designation of the bearing (`signatelec bearings`): its geometry places "
        "the ball-pass and the defects' characteristic lines (default: the bearing the model "
        "learnt, the seed's for the default model; the load state is estimated for that bearing "
        "only).",
    )(command)


def _bearing(designation: str | None):
    """The catalogue bearing of ``--bearing`` (None: the seed's), or InputError naming it."""
    if designation is None:
        return None
    from signatelec.config.catalogue import CatalogueError, catalogue_bearing

    try:
        return catalogue_bearing(designation)
    except CatalogueError as exc:
        # the catalogue names the scene key; here the option is the field
        raise InputError(f"--bearing {designation!r}: {str(exc).split(': ', 1)[-1]}") from None


def _note(message: str) -> None:
    """A line of the model's loading (a build, a warning) on stderr."""
    click.echo(f"signatelec: {message}", err=True)


def _check_prior(model, healthy_prior) -> None:
    """InputError unless ``model``'s condition model can report under ``healthy_prior``."""
    if healthy_prior is None:
        return
    if model.condition is None:
        raise InputError(f"--healthy-prior {healthy_prior!r}: the model has no condition model")
    try:
        model.condition.prior_shares(healthy_prior)
    except ValueError as exc:
        raise InputError(f"--healthy-prior: {exc}") from None


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
@bearing_option
@healthy_prior_option
@trace_columns
@click.option("--quiet", is_flag=True, help="No summary.")
def estimate(
    trace_file, omega_rad_s, model_path, out, designation, healthy_prior, time_column,
    resistance_column, quiet,
):  # fmt: skip
    """Estimate F_r, epsilon, clearance and regime from a resistance trace (CSV or Parquet).

    The trace needs at least 5 ball passes; isolated missing samples, small gaps and uneven
    sampling are repaired and a set-up transient is cut off; a trace whose ball-pass ripple is
    not at the frequency --omega predicts, whose level is outside the model's range or whose
    features are unlike its training traces is refused (exit 2).
    """
    from signatelec.estimation.condition import check_healthy_prior
    from signatelec.estimation.domain import DomainError
    from signatelec.estimation.estimate import estimate as run_estimate
    from signatelec.estimation.estimate import under_prior
    from signatelec.estimation.persistence import ModelError, default_model, load_model
    from signatelec.estimation.report import format_estimate
    from signatelec.estimation.report import write_result as write_estimate
    from signatelec.measurement.files import read_trace
    from signatelec.measurement.traces import TraceError, prepare_trace

    if out is not None:
        check_writable_file(out, suffixes=(".json", ".parquet"))
    try:
        check_healthy_prior(healthy_prior)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    bearing = _bearing(designation)
    from signatelec.io import TRACE_MAX_BYTES, input_size_problem

    problem = input_size_problem(trace_file, TRACE_MAX_BYTES)
    if problem:
        raise InputError(f"trace {trace_file!r}: {problem}")
    try:  # a model file first, quick to load: the bearing it learnt is the trace's default
        model = load_model(model_path, log=_note) if model_path else None
    except ModelError as exc:
        raise InputError(str(exc)) from None
    if bearing is None and model is not None:
        bearing = model.bearing
    try:  # before the default model (the seed's bearing's), whose first build takes minutes
        t, r, phase = read_trace(trace_file, time_column, resistance_column)
        trace = prepare_trace(
            t, r, omega_rad_s, source=f"trace {trace_file!r}", phase=phase, bearing=bearing
        )
    except TraceError as exc:
        raise InputError(str(exc)) from None
    if model is None:
        try:
            model = default_model(log=_note)
        except ModelError as exc:
            raise InputError(str(exc)) from None
    _check_prior(model, healthy_prior)
    try:
        result = run_estimate(trace, omega_rad_s, model, bearing=bearing)
    except (TraceError, DomainError) as exc:
        simulated = (
            isinstance(exc, DomainError) and phase is not None and NOISE_FREE.search(str(exc))
        )
        raise InputError(str(exc) + (SIMULATED if simulated else "")) from None
    if healthy_prior is not None:
        result = under_prior(result, model.condition, healthy_prior)
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
    from signatelec.estimation.training import features_from_dataset, table_bearing, train_model

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
        model = train_model(table, source=str(dataset), bearing=table_bearing(table))
    except ValueError as exc:
        raise InputError(f"{where}: {exc}") from None
    try:
        save_model(model, out)
    except OSError as exc:
        raise InputError(f"--out {out!r}: cannot write there ({exc.strerror or exc})") from None
    if not quiet:
        info = model.info
        of = f" of the {info['bearing']}" if info.get("bearing") else ""
        click.echo(
            f"trained on {info['n_rows']} traces of {info['n_runs']} runs{of} "
            f"({', '.join(info['targets'])}) in {info['fit_s']:.1f} s; wrote {out}"
        )


@cli.command()
@click.argument("trace_file", metavar="TRACE", type=str)
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option("--omega", "omega_rad_s", type=float, default=None, help="Inner-ring speed, rad/s.")
@click.option(
    "--speed-column",
    default=None,
    help="Column of the inner-ring speed (rad/s) per sample, instead of --omega.",
)
@click.option(
    "--track-speed",
    is_flag=True,
    help="Follow a slowly varying speed from the ball-pass frequency, starting at --omega.",
)
@click.option("--window", "window_s", type=float, default=0.2, show_default=True, help="Window, s.")
@click.option(
    "--hop", "hop_s", type=float, default=None, help="Hop between windows, s (default: --window)."
)
@click.option(
    "--false-alarm-rate",
    type=float,
    default=0.1,
    show_default=True,
    help="Expected false changes per hour of trace, of the load state and the condition "
    "together (shared equally between their series; sets the change detector's threshold).",
)
@click.option(
    "--load-threshold",
    type=float,
    default=0.05,
    show_default=True,
    help="Relative change of F_r that counts as a load change (and alarm).",
)
@click.option(
    "--condition-every",
    "condition_every_s",
    type=float,
    default=None,
    help="Trace between two assessments of the bearing's condition, s (default: one a minute; "
    "0: none).",
)
@healthy_prior_option
@click.option("--model", "model_path", type=str, default=None, help="Model file (as for estimate).")
@bearing_option
@trace_columns
@click.option(
    "--follow", is_flag=True, help="Keep reading a CSV file as it grows; Ctrl-C ends and writes."
)
@click.option(
    "--idle",
    "idle_s",
    type=float,
    default=None,
    help="With --follow: also end when the file has not grown for this many seconds.",
)
@click.option("--quiet", is_flag=True, help="No progress or summary.")
def monitor(
    trace_file, out, omega_rad_s, speed_column, track_speed, window_s, hop_s, false_alarm_rate,
    load_threshold, condition_every_s, healthy_prior, model_path, designation, time_column,
    resistance_column, follow, idle_s, quiet,
):  # fmt: skip
    """Monitor a long resistance trace: per-window load state, stretches, changes and alarms.

    Reads TRACE (CSV or Parquet) in chunks, so any length fits in memory, or CSV piped to
    standard input when TRACE is - (read to its end; Ctrl-C ends and writes); writes
    DIR/windows.parquet (one row per window), DIR/summary.json (stretches, changes, alarms)
    and DIR/monitor.png.
    """
    from signatelec.cli.common import claim_output, write_output
    from signatelec.estimation.condition import check_healthy_prior
    from signatelec.estimation.evidence import (
        bias_ratios,
        check_settings,
        report_under_prior,
        stretches_and_changes,
    )
    from signatelec.estimation.health import CONDITION_EVERY_S
    from signatelec.estimation.monitor import MonitorSettings, monitor_trace
    from signatelec.estimation.monitor_answers import KEPT_FEATURES, kept_features
    from signatelec.estimation.monitor_report import (
        COMMAND,
        LiveAlarms,
        summary_of,
        write_monitor,
    )
    from signatelec.estimation.persistence import ModelError, default_model, load_model
    from signatelec.io import input_size_problem
    from signatelec.measurement.stream import check_trace_file, is_standard_input, trace_label
    from signatelec.measurement.traces import TraceError

    settings = MonitorSettings(
        omega_rad_s=omega_rad_s,
        speed_column=speed_column,
        track_speed=track_speed,
        window_s=window_s,
        hop_s=hop_s,
        time_column=time_column,
        resistance_column=resistance_column,
        follow=follow,
        follow_idle_s=idle_s,
        condition_every_s=(
            CONDITION_EVERY_S
            if condition_every_s is None
            else (None if condition_every_s == 0 else condition_every_s)
        ),
        bearing=_bearing(designation),
    )
    try:  # TraceError is a ValueError: the Python functions refuse with the same line
        settings = settings.for_trace(trace_file)
        settings.check()
        if model_path is None:  # the default model's bearing, the seed's: told at once
            settings.check_speed()
        check_settings(settings.hop, false_alarm_rate, load_threshold)
        check_healthy_prior(healthy_prior)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    problem = None if is_standard_input(trace_file) else input_size_problem(trace_file, 1 << 62)
    if problem:
        raise InputError(f"{trace_label(trace_file)}: {problem}")
    claim_output(out, COMMAND)
    try:  # before the model, whose first build takes minutes: the file, its format, its columns
        check_trace_file(trace_file, time_column, resistance_column, speed_column, follow=follow)
    except TraceError as exc:
        raise InputError(str(exc)) from None
    try:
        model = load_model(model_path, log=_note) if model_path else default_model(log=_note)
    except ModelError as exc:
        raise InputError(str(exc)) from None
    _check_prior(model, healthy_prior)  # before the trace is read
    settings = settings.for_model(model)
    try:
        settings.check_model(model)
    except TraceError as exc:
        raise InputError(str(exc)) from None
    # the model's objects live until the end: the collector need not walk them again and again
    # (~1 s an hour of trace with the stretch model's trees); unfrozen once the trace is read,
    # so that whatever was garbage then is collected after (a full collection first: 0.14 s)
    gc.freeze()
    extra = {
        "false_alarm_rate_per_hour": false_alarm_rate,
        "load_threshold": load_threshold,
        "condition_every_s": settings.condition_every_s if model.condition else None,
        "condition_training_mix": model.condition.training_mix if model.condition else None,
        "healthy_prior": healthy_prior,
    }

    def summarise(table, windows=None) -> dict:
        """The summary of the windows read so far (the output's, and the live alarms');
        ``windows``: the table's frame, when at hand."""
        stretches, changes, alarms = stretches_and_changes(
            table.frame() if windows is None else windows,
            settings.hop,
            false_alarm_rate,
            load_threshold,
            bias_ratios(model),
            # the seed's bearing's load-state models (another's windows carry no load state)
            stretch_model=model.stretch if settings.load_state else None,
            faulty_model=model.faulty if settings.load_state else None,
            gaps=table.gaps,
        )
        summary = summary_of(table, settings, stretches, changes, alarms, extra, model)
        if healthy_prior is not None:  # the calls, changes and warnings stay the training mix's
            report_under_prior(
                summary["stretches"], summary["changes"], summary["alarms"], model.condition,
                healthy_prior,
            )  # fmt: skip
            summary["notes"].append(model.condition.prior_note(healthy_prior))
        return summary

    # a record still being written (a followed file, standard input): its alarms on the way
    live = LiveAlarms(summarise, settings.hop) if settings.follow else None
    progress = None if quiet else _progress_printer(trace_file, live)
    try:
        table = monitor_trace(trace_file, model, settings, progress=progress)
    except TraceError as exc:
        raise InputError(str(exc)) from None
    finally:
        gc.unfreeze()
    windows = table.frame()
    summary = summarise(table, windows)
    if healthy_prior is not None:
        windows = model.condition.move_to_prior(windows, healthy_prior)
    # the model's own features served the stretch model; the table keeps those it kept before
    # (~0.2 s an hour of 50 kHz trace to write them all)
    spare = [c for c in kept_features(model) if c not in (*KEPT_FEATURES, "omega_rad_s")]
    write_output(lambda: write_monitor(out, windows.drop(columns=spare, errors="ignore"), summary))
    # the output is in place and complete: a Ctrl-C from here on would only make exit code 130
    # ("interrupted", as if nothing had been written) of a run that finished
    with signals_deferred():
        _report(out, windows, summary, table.interrupted, quiet)


def _report(out, windows, summary, interrupted: bool, quiet: bool) -> None:
    """The lines the monitor prints once its output is written."""
    from signatelec.estimation.monitor_report import format_summary

    if interrupted and not quiet:
        click.echo(
            f"signatelec: monitor: stopped following at Ctrl-C; wrote the {len(windows)} windows "
            "analysed",
            err=True,
        )
    if not quiet:
        click.echo(format_summary(summary))
        click.echo(f"wrote {out}/windows.parquet, summary.json, monitor.png")


def _progress_printer(trace_file: str, live=None, every_s: float = 2.0):
    """Progress lines on stderr, at most one per ``every_s`` of wall time, and the new alarms
    that ``live`` (:class:`~signatelec.estimation.monitor_report.LiveAlarms`) finds."""
    import time

    total = None
    if trace_file.lower().endswith((".parquet", ".pq")):
        try:
            import pyarrow.parquet as pq

            total = pq.ParquetFile(trace_file).metadata.num_rows
        except (OSError, ValueError):
            total = None
    last = [time.monotonic()]

    def show(table) -> None:
        for line in live(table) if live is not None else ():
            click.echo(f"signatelec: monitor: {line}", err=True)
        now = time.monotonic()
        if now - last[0] < every_s or not table.sample_rate_hz:
            return
        last[0] = now
        seconds = table.duration_s
        share = f" ({table.n_samples / total:.0%})" if total else ""
        # (no rate before the first windows are filed: the model is asked in batches; another
        # bearing's windows are filed with their condition alone)
        rate = seconds / table.cpu_s if table.n_windows and table.cpu_s > 0 else None
        speed = "" if rate is None else f", {rate:.0f}x real time"
        click.echo(
            f"signatelec: monitor: {seconds:.1f} s of trace read{share}, {table.n_windows} "
            f"windows done{speed}",
            err=True,
        )

    return show
