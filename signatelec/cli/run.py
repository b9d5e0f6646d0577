"""Commands that run the model: ``simulate``, ``bearings``, ``bench``, ``figures``."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import replace
from pathlib import Path

import click

from signatelec.cli.common import (
    EXIT_DIVERGED,
    InputError,
    Stopped,
    check_writable_file,
    claim_output,
    cli,
    load_scene,
    scene_source,
    write_output,
)
from signatelec.config.scene import SceneError
from signatelec.engines.fidelity import FIDELITY_NAMES
from signatelec.io import write_bytes_atomic


@cli.command()
@click.option("--scene", "scene_file", type=str, default=None, help="Scene TOML (default: seed).")
@click.option("--radial-load", "radial_load_n", type=float, help="Radial load F_r, N.")
@click.option("--clearance", "clearance_m", type=float, help="Radial clearance (<0: preload), m.")
@click.option("--omega", "omega_rad_s", type=float, help="Inner-ring speed, rad/s.")
@click.option("--duration", "duration_s", type=float, help="Simulated time, s.")
@click.option("--dt", "dt_s", type=float, help="Time step, s.")
@click.option(
    "--sample-rate", "sample_rate_hz", type=float, help="Recorded instants per second, Hz."
)
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
    sample_rate_hz,
    fidelity,
    designation,
    out,
    quiet,
):
    """Simulate a scene; write DIR/balls.parquet and DIR/signals.parquet.

    The tables are written as the run goes, a block of recorded instants at a time (memory
    bounded whatever the duration); DIR appears, or is replaced, when the run completes. The time
    step, spin-up and duration not given are chosen for the scene (dt within its
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
        "sample_rate_hz": sample_rate_hz,
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
    from signatelec.engines.budget import check_run
    from signatelec.io import is_simulate_output

    try:
        # steps, recorded instants, memory, disk: before anything is written
        check_run(scene, out_dir=out)
    except SceneError as exc:
        raise InputError(f"{scene_source(scene_file, overrides)}: {exc}") from None
    claim_output(out, "simulate", previous=is_simulate_output)
    _warn_speed(scene, "--omega" if omega_rad_s is not None else "operating.omega_rad_s")
    results = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            # the tables go to a temporary directory beside DIR as the run goes
            write_output(lambda: results.append(run(scene, progress=not quiet, out_dir=out)))
        for w in caught:
            click.echo(f"signatelec: warning: {w.message}", err=True)
        _warn_record_rate(scene)
        _warn_settling(scene, out)
    except SceneError as exc:
        raise InputError(f"{scene_source(scene_file, overrides)}: {exc}") from None
    except DivergenceError as exc:
        raise Stopped(f"{exc}; nothing written", EXIT_DIVERGED) from None
    result = results[0]
    if not quiet:
        click.echo(summary(result, out))


#: A speed up to this factor above the limiting speed is that speed, rounded (1152 rad/s for the
#: 6208's 11 000 rpm, 1151.9 rad/s).
LIMITING_SPEED_TOLERANCE = 1.005


def _warn_speed(scene, key: str) -> None:
    """One line, before the run, when the speed is above the bearing's catalogue limiting
    speed (a run there is allowed: the scene's own limit is the balls' centrifugal overlap),
    asking whether it was given in a unit that would bring it within."""
    from signatelec.config.catalogue import designation_of, limiting_speed_rad_s
    from signatelec.measurement.band import SPEED_UNITS

    designation = designation_of(scene.bearing)
    if designation is None:
        return
    omega, limit = scene.operating.omega_rad_s, limiting_speed_rad_s(designation)
    if omega <= limit * LIMITING_SPEED_TOLERANCE:
        return
    units = [
        f"{unit} ({omega:g} {unit} = {omega * rad_s:.4g} rad/s)"
        for unit, rad_s in SPEED_UNITS.items()
        if omega * rad_s <= limit
    ]
    question = f"; was it a speed in {' or '.join(units)}?" if units else ""
    click.echo(
        f"signatelec: warning: {key} = {omega:g} rad/s is {omega / limit:.3g} x the "
        f"{scene.bearing.name.split(' (')[0]}'s limiting speed, {limit:.4g} rad/s "
        f"({limit * 60.0 / (2.0 * math.pi):.5g} rpm, catalogue){question}",
        err=True,
    )


def _warn_record_rate(scene) -> None:
    """One line when a time step given off the record grid makes the run record at another
    rate than asked (the outputs' timings hold the rate recorded, record_rate_hz)."""
    from signatelec.engines.results import record_rate_hz

    asked, recorded = scene.numerics.sample_rate_hz, record_rate_hz(scene)
    if abs(recorded / asked - 1.0) > 1e-9:
        click.echo(
            f"signatelec: warning: sample rate {asked:g} Hz asked, but dt = "
            f"{scene.numerics.dt_s:.6g} s records every {scene.record_every} steps, at "
            f"{recorded:.6g} Hz (timings record_rate_hz); a dt that divides "
            f"1/{asked:g} s records at the rate asked",
            err=True,
        )


#: The steady phase's mean resistance may differ from its settled part's by this much, relative,
#: before simulate warns that it still settles.
SETTLING_WARN_REL = 1e-3


def _warn_settling(scene, out: str) -> None:
    """One line when the ring and cage still settle into the steady phase: its level, read per
    ball pass, departs at its start from the level it settles to, as ``estimate``'s set-up trim
    reads a trace (:func:`~signatelec.measurement.settling.trim_transient`), and moves the
    steady mean resistance by more than :data:`SETTLING_WARN_REL` (a run of the automatic
    duration at 3000 N with a 10 um clearance starts 2 % low, its mean 0.5 % low). Numpy and
    pyarrow only (read as the stream reads its steady means): a run imports neither pandas nor
    scipy."""
    import numpy as np
    import pyarrow.parquet as pq

    from signatelec.engines.results import in_steady_phase, record_rate_hz
    from signatelec.engines.stream import arrow_numbers
    from signatelec.measurement.settling import trim_transient
    from signatelec.measurement.traces import Trace, TraceError

    if scene.numerics.fidelity == "quasistatic" or not scene.outputs.electrical:
        return  # no transient, or no level to read
    signals = Path(out) / "signals.parquet"
    columns = ["time_s", "resistance_ohm"]  # (read_table would import pandas for its metadata)
    table = pq.ParquetFile(signals).read(columns=columns, use_pandas_metadata=False)
    t = arrow_numbers(table.column("time_s"))
    steady = in_steady_phase(t, scene)
    t, r = t[steady], arrow_numbers(table.column("resistance_ohm"))[steady]
    if r.size < 4 or not np.isfinite(r).all():
        return
    trace = Trace(t - t[0], r, record_rate_hz(scene), str(signals))
    try:
        kept = trim_transient(trace, scene.operating.omega_rad_s, bearing=scene.bearing)
    except TraceError as exc:
        found, effect = str(exc), ""
    else:
        off = float(np.mean(r) / np.mean(kept.resistance_ohm)) - 1.0
        if abs(off) <= SETTLING_WARN_REL:
            return
        found = kept.repairs[-1]
        effect = f" (the mean resistance {off:+.2%} off the settled part's)"
    click.echo(
        "signatelec: warning: the steady phase starts before the ring and cage have settled "
        f"({found}); its steady means include that part{effect}: a longer --duration gives "
        "more settled ball passes",
        err=True,
    )


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
    st = result.steady_means()
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
    if st and not math.isnan(st["time_s"]):
        kin = b.cage_speed_rad_s(sc.operating.omega_rad_s)
        lines.append(
            f"steady state: delta_r = {st['delta_r_m'] * 1e6:.2f} um, epsilon = "
            f"{st['epsilon']:.3f}, max ball load = {st['max_ball_load_n']:.1f} N, "
            f"loaded balls = {st['loaded_balls']:.2f}, cage speed = "
            f"{st['cage_speed_rad_s']:.2f} rad/s (kinematic {kin:.2f})"
        )
        if "impedance_ohm" in st:
            lines.append(
                f"lubricated ({sc.lubricant.oil} at {sc.lubricant.temperature_c:g} C): smallest "
                f"film parameter {st['film_parameter_min']:.3g} (steady mean), DC resistance "
                f"{st['resistance_ohm']:.4g} Ohm, at {sc.operating.measurement_frequency_hz:g} Hz "
                f"|Z| = {st['impedance_ohm']:.4g} Ohm, phase {st['impedance_phase_rad']:.3f} rad, "
                f"C = {st['capacitance_f'] * 1e12:.1f} pF"
            )
        elif "resistance_ohm" in st:
            lines.append(f"resistance: mean {st['resistance_ohm'] * 1e3:.4f} mOhm")
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
@click.option(
    "--tiers",
    is_flag=True,
    help="Instead of the cases: the marginal CPU per simulated second of the DEM and of the "
    "quasi-static tier (seed scene, same process, best and median of 7 interleaved pairs).",
)
@click.option(
    "--start-up",
    "start_up",
    is_flag=True,
    help="Instead of the cases: the whole-process CPU and wall time of `signatelec simulate` "
    "on the seed scene, warm, and its time to first step (medians of 7 runs).",
)
@click.option(
    "--batch-sizes",
    "batch_sizes",
    type=str,
    default="1,2,4,8,16,32",
    show_default=True,
    help="Batch sizes of the ensemble kernel to measure the seed scene at, CPU us per "
    "scene-step against the single-scene kernel (comma-separated; empty: none).",
)
def bench(out, duration_s, fresh_cache, cases, tiers, start_up, batch_sizes):
    """Cost of the seed scene and of each scene option (us per step, compile apart), and of
    the seed scene in batches of the ensemble kernel (us per scene-step)."""
    from signatelec.studies.bench import (
        format_batch_table,
        format_table,
        run_batch_bench,
        run_bench,
        select_cases,
    )

    check_writable_file(out, suffixes=(".json",))
    if start_up or tiers:
        from signatelec.studies.bench import startup_cost, tier_marginal_cost

        if start_up:
            report = startup_cost()
            line = (
                f"signatelec simulate (seed scene, warm), medians of {report['repeat']}: CPU "
                f"{report['median_cpu_s']:.3f} s, wall {report['median_wall_s']:.3f} s, first "
                f"step at {report['median_first_step_s']:.3f} s (load average "
                f"{report['load_average'][0]:.1f})"
            )
        else:
            report = tier_marginal_cost()
            line = (
                f"CPU s per simulated s at {report['sample_rate_hz']:g} Hz: DEM "
                f"{report['dem_cpu_s_per_simulated_s']:.4g}, quasi-static tier "
                f"{report['quasistatic_cpu_s_per_simulated_s']:.4g}; ratio {report['ratio']:.0f} "
                f"(best of {len(report['runs']['dem'])} pairs; of the medians "
                f"{report['median_ratio']:.0f}; user CPU only {report['user_ratio']:.0f})"
            )
        click.echo(line)
        write_bytes_atomic(out, json.dumps(report, indent=2).encode("utf-8"))
        click.echo(f"wrote {out}")
        return
    try:
        sizes = tuple(int(v) for v in batch_sizes.split(",") if v.strip())
    except ValueError:
        sizes = ()
    if not all(1 <= size <= 4096 for size in sizes) or (batch_sizes.strip() and not sizes):
        raise InputError(
            f"--batch-sizes {batch_sizes!r}: comma-separated integers from 1 to 4096 (or empty)"
        )
    try:
        select_cases(cases)
        report = run_bench(duration_s=duration_s, fresh_cache=fresh_cache, cases=cases)
        if sizes:
            report["batch"] = run_batch_bench(sizes, duration_s)
    except SceneError as exc:
        raise InputError(str(exc)) from None
    click.echo(format_table(report))
    if sizes:
        click.echo(format_batch_table(report["batch"]))
    write_bytes_atomic(out, json.dumps(report, indent=2).encode("utf-8"))
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
