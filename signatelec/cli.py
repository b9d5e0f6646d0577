"""Command line: ``signatelec simulate | generate | figures | ...``.

Errors in the input print one line ``signatelec: error: <input>: <field> = <value>: <rule>`` and
exit with code 2, leaving nothing behind. Every exit code is listed in :data:`EXIT_CODES` (shown
by ``signatelec --help`` and in the README). Output directories follow the contract of
:mod:`signatelec.io`: checked before any work, replaced atomically, temporaries of killed runs
removed by the next run.
"""

from __future__ import annotations

import contextlib
import json
import signal
import sys
import warnings
from pathlib import Path


def _interrupted_while_starting(signum, frame) -> None:
    """Ctrl-C before :func:`main` runs (the imports take a second): one line, exit 130."""
    sys.stderr.write("signatelec: interrupted\n")
    raise SystemExit(128 + signal.SIGINT)


with contextlib.suppress(ValueError):  # only the main thread may set handlers
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupted_while_starting)

import click  # noqa: E402

from signatelec.config.scene import Scene, SceneError  # noqa: E402
from signatelec.engines.fidelity import FIDELITY_NAMES  # noqa: E402
from signatelec.io import OutputError, OutputIncomplete, check_output_dir  # noqa: E402

EXIT_OK = 0
EXIT_INPUT = 2
EXIT_DIVERGED = 3
#: EX_TEMPFAIL of sysexits.h: not complete; rerunning the same command can finish it.
EXIT_INCOMPLETE = 75
EXIT_INTERRUPTED = 128 + signal.SIGINT
EXIT_TERMINATED = 128 + signal.SIGTERM

EXIT_CODES = (
    (EXIT_OK, "complete"),
    (1, "unexpected error (a bug); the traces generate wrote are kept"),
    (EXIT_INPUT, "refused: bad input or output location; nothing written"),
    (EXIT_DIVERGED, "the simulation diverged; nothing written"),
    (
        EXIT_INCOMPLETE,
        "incomplete (disk full, I/O error, a worker or the cluster lost): simulate and figures "
        "wrote nothing, generate kept the traces written; rerun the same command to resume",
    ),
    (EXIT_INTERRUPTED, "interrupted (Ctrl-C); as 75"),
    (EXIT_TERMINATED, "terminated (SIGTERM); as 75"),
)


def _exit_code_table() -> str:
    """The exit codes as ``--help`` shows them (``\b``: click keeps the lines as they are)."""
    import textwrap

    lines = ["\b", "Exit codes:"]
    for code, text in EXIT_CODES:
        wrapped = textwrap.wrap(text, 66)
        lines.append(f"  {code:>3}  {wrapped[0]}")
        lines.extend(f"       {line}" for line in wrapped[1:])
    return "\n".join(lines)


class InputError(click.ClickException):
    exit_code = EXIT_INPUT


class Stopped(click.ClickException):
    """A run that stopped before completing; the message says what is kept."""

    def __init__(self, message: str, exit_code: int):
        super().__init__(message)
        self.exit_code = exit_code


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that the same clean-up runs."""


def _stop_code(exc: BaseException) -> int:
    return EXIT_TERMINATED if isinstance(exc, Terminated) else EXIT_INTERRUPTED


def _stop_word(exc: BaseException) -> str:
    return "terminated" if isinstance(exc, Terminated) else "interrupted"


class _Group(click.Group):
    """A command interrupted by Ctrl-C or SIGTERM ends with one line and its exit code (click
    itself would print a blank line and "Aborted!")."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as exc:
            raise Stopped(_stop_word(exc), _stop_code(exc)) from None


#: Command-line options of the scene parameters they override, to name them in errors.
OVERRIDE_OPTIONS = {
    "radial_load_n": "--radial-load",
    "clearance_m": "--clearance",
    "omega_rad_s": "--omega",
    "duration_s": "--duration",
    "dt_s": "--dt",
}


def scene_source(scene_file: str | None, overrides: dict | None = None) -> str:
    """Where a scene came from, for error messages: the file and the options that changed it."""
    where = f"scene {scene_file!r}" if scene_file is not None else "default scene"
    given = [
        f"{OVERRIDE_OPTIONS.get(k, k)} {v!r}" for k, v in (overrides or {}).items() if v is not None
    ]
    return f"{where} with {', '.join(given)}" if given else where


def load_scene(scene_file: str | None, **overrides) -> Scene:
    try:
        scene = Scene.from_toml(scene_file) if scene_file is not None else Scene()
    except SceneError as exc:
        message = str(exc)
        # a file that cannot be read or parsed names itself ("scene file '...': ...")
        where = "" if message.startswith("scene file") else f"{scene_source(scene_file)}: "
        raise InputError(f"{where}{message}") from None
    try:
        return scene.with_overrides(**overrides)
    except SceneError as exc:
        raise InputError(f"{scene_source(scene_file, overrides)}: {exc}") from None


def claim_output(out: str, command: str, **kwargs) -> Path:
    """Refuse, before a long run, an output location ``command`` may not write
    (:func:`signatelec.io.check_output_dir`); nothing is left behind."""
    try:
        return check_output_dir(out, command, **kwargs)
    except OutputError as exc:
        raise InputError(str(exc)) from None


@click.group(cls=_Group, epilog=_exit_code_table())
@click.version_option(package_name="signatelec")
def cli() -> None:
    """signatelec: DEM ball-bearing simulator and electrical resistance signatures."""


@cli.command()
@click.option("--scene", "scene_file", type=str, default=None, help="Scene TOML (default: seed).")
@click.option("--radial-load", "radial_load_n", type=float, help="Radial load F_r, N.")
@click.option("--clearance", "clearance_m", type=float, help="Radial clearance (<0: preload), m.")
@click.option("--omega", "omega_rad_s", type=float, help="Inner-ring speed, rad/s.")
@click.option("--duration", "duration_s", type=float, help="Simulated time, s.")
@click.option("--dt", "dt_s", type=float, help="Time step, s.")
@click.option(
    "--fidelity",
    type=click.Choice(FIDELITY_NAMES),
    default=None,
    help="Tier (quasistatic: steady phase, ms; dem) or preset (fast, balanced, reference; "
    "see README); an explicit --dt wins over the preset's.",
)
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option("--quiet", is_flag=True, help="No progress bar or summary.")
def simulate(
    scene_file, radial_load_n, clearance_m, omega_rad_s, duration_s, dt_s, fidelity, out, quiet
):
    """Simulate a scene; write DIR/balls.parquet and DIR/signals.parquet."""
    from signatelec.engines.results import DivergenceError
    from signatelec.engines.simulate import simulate as run

    overrides = {
        "radial_load_n": radial_load_n,
        "clearance_m": clearance_m,
        "omega_rad_s": omega_rad_s,
        "duration_s": duration_s,
        "dt_s": dt_s,
    }
    scene = load_scene(scene_file, **overrides)
    if fidelity is not None:
        from signatelec.engines.fidelity import apply_fidelity

        try:
            scene = apply_fidelity(scene, fidelity)
            if dt_s is not None:  # an explicit --dt wins over the preset's
                scene = scene.with_overrides(dt_s=dt_s)
        except SceneError as exc:
            where = scene_source(scene_file, overrides)
            raise InputError(f"{where} at --fidelity {fidelity}: {exc}") from None
    from signatelec.engines.budget import check_run
    from signatelec.io import is_simulate_output

    try:
        check_run(scene)  # steps, recorded instants, memory: before anything is written
    except SceneError as exc:
        raise InputError(f"{scene_source(scene_file, overrides)}: {exc}") from None
    claim_output(out, "simulate", previous=is_simulate_output)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = run(scene, progress=not quiet)
        for w in caught:
            click.echo(f"signatelec: warning: {w.message}", err=True)
    except SceneError as exc:
        raise InputError(f"{scene_source(scene_file, overrides)}: {exc}") from None
    except DivergenceError as exc:
        raise Stopped(f"{exc}; nothing written", EXIT_DIVERGED) from None
    except KeyboardInterrupt as exc:
        raise Stopped(f"{_stop_word(exc)}; nothing written", _stop_code(exc)) from None
    write_output(lambda: result.write(out))
    if not quiet:
        click.echo(summary(result, out))


def write_output(write) -> None:
    """Call ``write`` (an atomic replacement of the output directory) and give each way it can
    fail its exit code: refused (2), not written (75), interrupted (130, 143); nothing written."""
    try:
        write()
    except OutputError as exc:
        raise InputError(str(exc)) from None
    except OutputIncomplete as exc:
        raise Stopped(str(exc), EXIT_INCOMPLETE) from None
    except KeyboardInterrupt as exc:
        raise Stopped(f"{_stop_word(exc)}; nothing written", _stop_code(exc)) from None


def summary(result, out: str | None = None) -> str:
    """A readable summary of a run: timings and steady-state figures."""
    sc = result.scene
    t = result.timings
    st = result.steady()
    b = sc.bearing
    lines = [
        f"scene: F_r = {sc.operating.radial_load_n:g} N, clearance = "
        f"{sc.operating.clearance_m * 1e6:g} um, omega = {sc.operating.omega_rad_s:g} rad/s, "
        f"dt = {sc.numerics.dt_s:g} s, {sc.numerics.duration_s:g} s",
        f"run: {t['n_steps']} steps in {t['run_s']:.3f} s ({t['us_per_step']:.3f} us/step), "
        f"compile/load {t['compile_s']:.2f} s"
        if t.get("tier") != "quasistatic"
        else f"run: quasi-static tier, {t['n_instants']} steady instants in "
        f"{t['total_s'] * 1e3:.2f} ms, compile/load {t['compile_s']:.2f} s",
    ]
    if len(st):
        kin = b.cage_speed_rad_s(sc.operating.omega_rad_s)
        lines.append(
            f"steady state: delta_r = {st.delta_r_m.mean() * 1e6:.2f} um, epsilon = "
            f"{st.epsilon.mean():.3f}, max ball load = {st.max_ball_load_n.mean():.1f} N, "
            f"loaded balls = {st.loaded_balls.mean():.2f}, cage speed = "
            f"{st.cage_speed_rad_s.mean():.2f} rad/s (kinematic {kin:.2f})"
        )
        if "resistance_ohm" in st:
            lines.append(f"resistance: mean {st.resistance_ohm.mean() * 1e3:.4f} mOhm")
    if out:
        lines.append(f"wrote {out}/balls.parquet, {out}/signals.parquet")
    return "\n".join(lines)


@cli.command()
@click.option(
    "--out",
    "out",
    type=str,
    default="bench.json",
    show_default=True,
    help="JSON file for the figures.",
)
@click.option(
    "--duration",
    "duration_s",
    type=float,
    default=0.03,
    show_default=True,
    help="Simulated time per case, s.",
)
@click.option(
    "--fresh-cache/--warm-cache",
    default=True,
    show_default=True,
    help="Compile into an empty cache so compile time is measured.",
)
@click.option(
    "--case",
    "cases",
    multiple=True,
    help="Run only this case (repeatable): seed, cage=none, contact_law=linear, minimal, ... "
    "(default: every case).",
)
def bench(out, duration_s, fresh_cache, cases):
    """Cost of the seed scene and of each scene option (us per step, compile apart)."""
    from signatelec.studies.bench import format_table, run_bench, select_cases

    check_writable_file(out, suffixes=(".json",))
    try:
        select_cases(cases)
        report = run_bench(duration_s=duration_s, fresh_cache=fresh_cache, cases=cases)
    except SceneError as exc:
        raise InputError(str(exc)) from None
    click.echo(format_table(report))
    tmp = Path(out).with_name(Path(out).name + ".tmp")
    tmp.write_text(json.dumps(report, indent=2))
    tmp.replace(out)
    click.echo(f"wrote {out}")


@cli.command()
@click.option("--out", "out", type=str, required=True, help="Output directory for the PNGs.")
@click.option("--quick", is_flag=True, help="Short runs (set-up + 2 ms): a check, not the figures.")
@click.option("--quiet", is_flag=True, help="No progress bar or file list.")
def figures(out, quick, quiet):
    """Regenerate the seed's figures 6-11: DIR/figure_6_9.png, figure_7_10.png, figure_8_11.png."""
    from signatelec.engines.results import DivergenceError
    from signatelec.io import holds_only, replace_directory
    from signatelec.studies.paper_figures import FIGURE_FILES, paper_figures

    def previous(directory: Path) -> bool:  # figures written before the marker existed
        return holds_only(directory, FIGURE_FILES)

    claim_output(out, "figures", previous=previous)
    written: list[Path] = []

    def write() -> None:
        with replace_directory(out, "figures", previous=previous) as tmp:
            written.extend(Path(out) / p.name for p in paper_figures(tmp, **options))

    options = {"quick": quick, "progress": not quiet}
    try:
        write_output(write)
    except SceneError as exc:
        raise InputError(str(exc)) from None
    except DivergenceError as exc:
        raise Stopped(f"{exc}; nothing written", EXIT_DIVERGED) from None
    if not quiet:
        for path in written:
            click.echo(f"wrote {path}")


@cli.group()
def study() -> None:
    """Studies of the model (accuracy-cost, ...)."""


@study.command("accuracy-cost")
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option("--quick", is_flag=True, help="One scene, three settings: a pipeline check.")
@click.option("--fresh", is_flag=True, help="Ignore finished cases cached in DIR/.cache.")
@click.option("--quiet", is_flag=True, help="No progress bar or file list.")
def accuracy_cost(out, quick, fresh, quiet):
    """Fidelity ladder against a dt = 1e-8 s reference: DIR/accuracy_cost.{parquet,md,png}."""
    from signatelec.io import holds_only, write_marker
    from signatelec.studies.accuracy_cost import run_study

    own = ("accuracy_cost.parquet", "accuracy_cost.md", "accuracy_cost.png", ".cache")
    previous = lambda d: holds_only(d, own, False)  # noqa: E731
    claim_output(out, "study accuracy-cost", previous=previous, replaced=False)
    try:
        run_study(
            out, quick=quick, progress=not quiet, fresh=fresh, log=None if quiet else click.echo
        )
        write_marker(out, "study accuracy-cost")
    except OSError as exc:
        raise Stopped(
            f"--out {out!r}: cannot write there ({exc.strerror or exc}); finished cases are kept "
            "in DIR/.cache: rerun the same command to resume",
            EXIT_INCOMPLETE,
        ) from None


@cli.command()
@click.argument("spec_file", metavar="SPEC.toml", type=str)
@click.option("--out", "out", type=str, required=True, help="Dataset directory (resumable).")
@click.option(
    "--workers",
    type=int,
    default=None,
    help="Local worker processes (default: all cores; 0: run in this process).",
)
@click.option(
    "--scheduler",
    type=str,
    default=None,
    help="Dask scheduler address (e.g. tcp://127.0.0.1:8786): run on that cluster instead.",
)
@click.option("--quiet", is_flag=True, help="No progress bar or summary.")
def generate(spec_file, out, workers, scheduler, quiet):
    """Labelled resistance signatures of a dataset spec: DIR/regime=*/trace-*.parquet.

    A rerun of the same command skips the traces already written (a killed job resumes).
    """
    from signatelec.data import DatasetDirError, SpecError, load_spec
    from signatelec.data import generate as run_generate
    from signatelec.data.schedule import kept, stop_reason
    from signatelec.data.store import LOCK_FILE, is_dataset

    try:
        spec = load_spec(spec_file)
    except SpecError as exc:
        raise InputError(str(exc)) from None
    if workers is not None and workers < 0:
        raise InputError(f"--workers {workers}: must be >= 0 (0: run in this process)")
    if workers is not None and scheduler:
        raise InputError(f"--workers {workers}: give --workers or --scheduler, not both")
    # below DIR: regime=<regime>/<temporary name of a part file>
    claim_output(
        out, "generate", previous=is_dataset, ignore=(LOCK_FILE,), inner_bytes=100, replaced=False
    )

    def log(line: str) -> None:
        click.echo(f"signatelec: warning: {line}", err=True)

    try:
        summary_ = run_generate(
            spec, out, workers=workers, scheduler=scheduler, progress=not quiet, log=log
        )
    except (SpecError, DatasetDirError) as exc:  # refused before any trace was written
        raise InputError(str(exc)) from None
    except KeyboardInterrupt as exc:
        raise Stopped(f"{_stop_word(exc)}; {kept(out, spec)}", _stop_code(exc)) from None
    except Exception as exc:
        resumable, reason = stop_reason(exc)
        code = EXIT_INCOMPLETE if resumable else 1
        raise Stopped(f"generation stopped ({reason}); {kept(out, spec)}", code) from None
    if not quiet:
        click.echo(summary_.describe())


def check_writable_file(out: str, option: str = "--out", suffixes=None) -> None:
    """Fail early when a single output file cannot be written (its directory must exist)."""
    import os

    path = Path(out)
    if not out.strip() or path.is_dir():
        raise InputError(f"{option} {out!r}: must name a file")
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(f"{option} {out!r}: must end in {' or '.join(suffixes)}")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{option} {out!r}: {str(parent)!r} is not a writable directory")


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
    sampling are repaired, anything else is refused (exit 2).
    """
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
        t, r = read_trace(trace_file, time_column, resistance_column)
        trace = prepare_trace(t, r, omega_rad_s, source=f"trace {trace_file!r}")
    except TraceError as exc:
        raise InputError(str(exc)) from None
    try:
        if model_path:
            model = load_model(model_path)
        else:
            model = default_model(log=lambda m: click.echo(f"signatelec: {m}", err=True))
    except ModelError as exc:
        raise InputError(str(exc)) from None
    result = run_estimate(trace, omega_rad_s, model)
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
    features) or a Parquet feature table with labels (pipelines/load_state.py writes one).
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


def _raise_terminated(signum, frame) -> None:
    raise Terminated()


def one_line(text: str) -> str:
    """``text`` with line breaks and other control characters escaped (``\\r``, ``\\x1e``): an
    error stays one line whatever key, column or value of the input it names."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _error(message: str) -> None:
    click.echo(f"signatelec: error: {one_line(message)}", err=True)


def main(argv: list[str] | None = None) -> None:
    """The ``signatelec`` command; SIGTERM stops a run as Ctrl-C does (exit 143)."""
    previous = None
    with contextlib.suppress(ValueError):  # not the main thread: leave the handlers alone
        if signal.getsignal(signal.SIGINT) is _interrupted_while_starting:
            signal.signal(signal.SIGINT, signal.default_int_handler)
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        cli.main(args=argv, prog_name="signatelec", standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.Abort:
        click.echo("signatelec: interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except (InputError, Stopped) as exc:
        _error(exc.format_message())
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        _error(exc.format_message())
        sys.exit(EXIT_INPUT)
    except (SceneError, OutputError) as exc:
        _error(str(exc))
        sys.exit(EXIT_INPUT)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
