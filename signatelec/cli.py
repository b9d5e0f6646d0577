"""Command line: ``signatelec simulate | bench | ...``.

Errors in the input print one line ``signatelec: error: <input>: <field> = <value>: <rule>`` and
exit with code 2, leaving nothing behind; a run that diverges exits with code 3.
"""

from __future__ import annotations

import json
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import click

from signatelec.config.scene import Scene, SceneError
from signatelec.engines.fidelity import FIDELITY_NAMES
from signatelec.io import OutputError

EXIT_INPUT = 2
EXIT_DIVERGED = 3


class InputError(click.ClickException):
    exit_code = EXIT_INPUT


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
    where = f"scene {scene_file!r}" if scene_file else "default scene"
    given = [
        f"{OVERRIDE_OPTIONS.get(k, k)} {v!r}" for k, v in (overrides or {}).items() if v is not None
    ]
    return f"{where} with {', '.join(given)}" if given else where


def load_scene(scene_file: str | None, **overrides) -> Scene:
    try:
        scene = Scene.from_toml(scene_file) if scene_file else Scene()
    except SceneError as exc:
        message = str(exc)
        # a file that cannot be read or parsed names itself ("scene file '...': ...")
        where = "" if message.startswith("scene file") else f"{scene_source(scene_file)}: "
        raise InputError(f"{where}{message}") from None
    try:
        return scene.with_overrides(**overrides)
    except SceneError as exc:
        raise InputError(f"{scene_source(scene_file, overrides)}: {exc}") from None


def check_writable(out: str) -> None:
    """Fail before a long run when the output location cannot be written.

    The nearest existing ancestor of ``out`` must be a directory where a file can be created
    (probed with a temporary file, removed at once); nothing is left behind.
    """
    import os
    import tempfile

    if not out.strip():
        raise InputError(f"--out {out!r}: must name a directory")
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise InputError(f"--out {out!r}: exists and is not a directory; choose a directory")
    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
        raise InputError(f"--out {out!r}: {str(probe)!r} is not a writable directory")
    try:
        with tempfile.TemporaryFile(dir=probe, prefix=".signatelec-probe"):
            pass
    except OSError as exc:
        raise InputError(
            f"--out {out!r}: cannot create files in {str(probe)!r} ({exc.strerror or exc}); "
            "choose a writable directory"
        ) from None


@click.group()
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
@click.option(
    "--bearing",
    "designation",
    type=str,
    default=None,
    help="Catalogue bearing replacing the scene's (see `signatelec bearings`).",
)
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option("--quiet", is_flag=True, help="No progress bar or summary.")
def simulate(
    scene_file,
    radial_load_n,
    clearance_m,
    omega_rad_s,
    duration_s,
    dt_s,
    fidelity,
    designation,
    out,
    quiet,
):
    """Simulate a scene; write DIR/balls.parquet and DIR/signals.parquet.

    The time step, spin-up and duration not given are chosen for the scene (dt within its
    stability limit, at most 1e-7 s; a spin-up gentle enough for its speed, cage and clearance;
    a few ball passes of steady running); the summary says what was chosen.
    """
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
    if designation is not None:
        from signatelec.config.bearing import BearingError
        from signatelec.config.catalogue import catalogue_bearing

        try:
            scene = replace(scene, bearing=catalogue_bearing(designation))
        except (BearingError, SceneError) as exc:
            raise InputError(f"--bearing {designation!r}: {exc}") from None
    if fidelity is not None:
        from signatelec.engines.fidelity import apply_fidelity

        try:
            scene = apply_fidelity(scene, fidelity)
            if dt_s is not None:  # an explicit --dt wins over the preset's
                scene = scene.with_overrides(dt_s=dt_s)
        except SceneError as exc:
            where = scene_source(scene_file, overrides)
            raise InputError(f"{where} at --fidelity {fidelity}: {exc}") from None
    check_writable(out)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = run(scene, progress=not quiet)
        for w in caught:
            click.echo(f"signatelec: warning: {w.message}", err=True)
    except SceneError as exc:
        raise InputError(f"{scene_source(scene_file, overrides)}: {exc}") from None
    except DivergenceError as exc:
        click.echo(f"signatelec: error: {exc}", err=True)
        sys.exit(EXIT_DIVERGED)
    try:
        result.write(out)
    except OutputError as exc:
        raise InputError(str(exc)) from None
    if not quiet:
        click.echo(summary(result, out))


@cli.command()
@click.option("--csv", "as_csv", is_flag=True, help="Every column, sources included, as CSV.")
def bearings(as_csv):
    """List the bearing catalogue (`--bearing`, `[bearing] designation`): geometry, ratings,
    speeds, sources and the defect frequencies as orders of the shaft speed."""
    from signatelec.config.catalogue import list_bearings

    table = list_bearings()
    if as_csv:
        click.echo(table.to_csv(), nl=False)
        return
    mm = 1e3
    view = table.assign(
        ball_mm=table["ball_diameter_m"] * mm,
        pitch_mm=table["pitch_diameter_m"] * mm,
        r_in_mm=table["inner_race_radius_m"] * mm,
        r_out_mm=table["outer_race_radius_m"] * mm,
        c_r_kn=table["dynamic_load_rating_n"] / 1e3,
        c_0r_kn=table["static_load_rating_n"] / 1e3,
    )[
        [
            "n_balls",
            "ball_mm",
            "pitch_mm",
            "r_in_mm",
            "r_out_mm",
            "c_r_kn",
            "c_0r_kn",
            "limiting_speed_rpm",
            "mass_kg",
            "ftf_order",
            "bpfo_order",
            "bpfi_order",
            "bsf_order",
        ]
    ]
    click.echo(view.to_string(float_format=lambda v: f"{v:.5g}", na_rep="-"))
    click.echo("sources: signatelec bearings --csv; orders: multiples of the shaft frequency")


def _chosen(scene, key: str) -> str:
    return " (auto)" if key in scene.auto else ""


def summary(result, out: str | None = None) -> str:
    """A readable summary of a run: timings and steady-state figures."""
    sc = result.scene
    t = result.timings
    st = result.steady()
    b = sc.bearing
    lines = [
        f"scene: F_r = {sc.operating.radial_load_n:g} N, clearance = "
        f"{sc.operating.clearance_m * 1e6:g} um, omega = {sc.operating.omega_rad_s:g} rad/s, "
        f"dt = {sc.numerics.dt_s:.3g} s{_chosen(sc, 'numerics.dt_s')}, spin-up = "
        f"{sc.procedure.spin_up_time_s * 1e3:.3g} ms{_chosen(sc, 'procedure.spin_up_time_s')}, "
        f"{sc.numerics.duration_s:.4g} s{_chosen(sc, 'numerics.duration_s')}",
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
    from signatelec.studies.paper_figures import paper_figures

    check_writable(out)
    try:
        paths = paper_figures(out, quick=quick, progress=not quiet)
    except SceneError as exc:
        raise InputError(str(exc)) from None
    except DivergenceError as exc:
        click.echo(f"signatelec: error: {exc}", err=True)
        sys.exit(EXIT_DIVERGED)
    except OSError as exc:
        raise InputError(f"--out {out!r}: cannot write there ({exc.strerror or exc})") from None
    if not quiet:
        for path in paths:
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
    from signatelec.studies.accuracy_cost import run_study

    check_writable(out)
    try:
        run_study(
            out, quick=quick, progress=not quiet, fresh=fresh, log=None if quiet else click.echo
        )
    except OSError as exc:
        raise InputError(f"--out {out!r}: cannot write there ({exc.strerror or exc})") from None


@study.command("operating-map")
@click.option("--out", "out", type=str, required=True, help="Output directory.")
@click.option("--quick", is_flag=True, help="Three cells, two ball passes: a pipeline check.")
@click.option(
    "--cage",
    "cages",
    multiple=True,
    default=("balls",),
    show_default=True,
    help="Cage model(s) to map (repeatable; see the scene's effects.cage).",
)
@click.option("--fresh", is_flag=True, help="Ignore finished cells cached in DIR/.cache.")
@click.option("--quiet", is_flag=True, help="No progress or file list.")
def operating_map(out, quick, cages, fresh, quiet):
    """Every catalogue bearing at its rated speeds with the defaults: DIR/operating_map.{parquet,
    md,png}."""
    from signatelec.config.scene import OPTION_TABLE
    from signatelec.studies.operating_map import run_study

    option = OPTION_TABLE[("effects", "cage")]
    for cage in cages:
        if not option.accepts(cage):
            raise InputError(f"--cage {cage!r}: {option.rule}")
    check_writable(out)
    try:
        paths = run_study(
            out, quick=quick, cages=cages, fresh=fresh, log=None if quiet else click.echo
        )
    except OSError as exc:
        raise InputError(f"--out {out!r}: cannot write there ({exc.strerror or exc})") from None
    if not quiet:
        for path in paths.values():
            click.echo(f"wrote {path}")


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

    try:
        spec = load_spec(spec_file)
    except SpecError as exc:
        raise InputError(str(exc)) from None
    if workers is not None and workers < 0:
        raise InputError(f"--workers {workers}: must be >= 0 (0: run in this process)")
    if workers is not None and scheduler:
        raise InputError(f"--workers {workers}: give --workers or --scheduler, not both")
    check_writable(out)
    try:
        summary_ = run_generate(spec, out, workers=workers, scheduler=scheduler, progress=not quiet)
    except DatasetDirError as exc:
        raise InputError(str(exc)) from None
    except OSError as exc:
        raise InputError(f"--out {out!r}: cannot write there ({exc.strerror or exc})") from None
    except Exception as exc:  # a worker died or the cluster failed: what is written stays
        click.echo(
            f"signatelec: error: generation stopped ({type(exc).__name__}: {exc}); the traces "
            "written are kept: rerun the same command to resume",
            err=True,
        )
        sys.exit(1)
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


def main(argv: list[str] | None = None) -> None:
    try:
        cli.main(args=argv, prog_name="signatelec", standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.Abort:
        click.echo("signatelec: aborted", err=True)
        sys.exit(130)
    except click.ClickException as exc:
        click.echo(f"signatelec: error: {exc.format_message()}", err=True)
        sys.exit(EXIT_INPUT)
    except (SceneError, OutputError) as exc:
        click.echo(f"signatelec: error: {exc}", err=True)
        sys.exit(EXIT_INPUT)
