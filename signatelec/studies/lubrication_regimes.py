"""The lubrication regime map: where the seed's dry-contact model holds, and what is read if not.

The seed's bearing (the 6208's 2D model) on the quasi-static tier with ``effects.lubrication``
on, over the inner-ring speed (geometric from 1 rpm to the 6208's limiting speed, 11 000 rpm),
the radial load (shares of C_r) and the oil temperature (ISO VG 68 by default). Each cell
records, as medians over one ball pass: the smallest film parameter Lambda of the loaded
contacts and its regime, the heaviest ball's central films, the bearing's DC resistance against
the dry model's (the same scene with lubrication off), |Z|, phase and parallel capacitance at
``operating.measurement_frequency_hz``, and the capacitance the Hertz zones alone would give
(the naive model the literature finds 3-11 times too small).

The dry model "holds" in a cell when the lubricated DC resistance is within
:data:`DRY_RTOL` of the dry model's. Writes ``lubrication_regimes.parquet``,
``lubrication_regimes.md``, ``lubrication_regimes.png`` and ``bode.png`` (the impedance over
frequency at one instant in each regime). The markdown also splits the full-film capacitance of
the seed's scene into its parts (:func:`capacitance_breakdown`) over the meniscus gap, the one
free parameter of the outside-zone term, for comparison with measured bearings.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.config.catalogue import rated_entry
from signatelec.config.scene import Scene
from signatelec.engines.simulate import simulate
from signatelec.io import write_bytes_atomic
from signatelec.physics.lubricated_contact import EPSILON_0_F_M
from signatelec.plots import new_figure, save_figure

LOWEST_RPM = 1.0
N_SPEEDS = 32
LOAD_FRACTIONS = (0.05, 0.2, 0.5)
TEMPERATURES_C = (40.0, 70.0, 100.0)
#: Samples per ball pass and ball passes of a cell's steady window.
SAMPLES_PER_PASS = 48
#: The dry model holds where the lubricated DC resistance is within this of the dry one.
DRY_RTOL = 0.10
RPM = 2.0 * math.pi / 60.0


def speeds_rad_s(n: int = N_SPEEDS) -> np.ndarray:
    return np.geomspace(LOWEST_RPM, rated_entry("seed").limiting_speed_rpm, n) * RPM


def cell_scene(omega_rad_s: float, load_fraction: float, temperature_c: float) -> Scene:
    """The seed's scene on the quasi-static tier, lubricated, one ball pass sampled."""
    base = Scene()
    f_bp = base.bearing.ball_pass_frequency_hz(omega_rad_s)
    return Scene.from_dict(
        {
            "operating": {
                "omega_rad_s": omega_rad_s,
                "radial_load_n": load_fraction * base.bearing.dynamic_load_rating_n,
            },
            "effects": {"lubrication": True},
            "lubricant": {"temperature_c": temperature_c},
            "numerics": {
                "fidelity": "quasistatic",
                "sample_rate_hz": SAMPLES_PER_PASS * f_bp,
                "duration_s": base.setup_time_s + 1.0 / f_bp,
            },
        }
    )


def hertz_only_capacitance_f(result) -> np.ndarray:
    """Per instant, the capacitance of the Hertz zones alone (parallel plates at h_c, the two
    contacts of a loaded ball in series, the balls in parallel), F."""
    b, n = result.balls, len(result.signals)
    z = result.scene.bearing.n_balls
    eps = EPSILON_0_F_M * result.scene.lubricant.resolved().relative_permittivity
    c = {}
    for race in ("inner", "outer"):
        area = b[f"{race}_area_m2"].to_numpy().reshape(n, z)
        c[race] = eps * area / b[f"{race}_film_m"].to_numpy().reshape(n, z)
    both = (c["inner"] > 0) & (c["outer"] > 0)
    series = np.divide(
        c["inner"] * c["outer"], c["inner"] + c["outer"], out=np.zeros((n, z)), where=both
    )
    return series.sum(axis=1)


#: Meniscus gaps (m) of the capacitance breakdown: the model's default 50 um and a decade around.
MENISCUS_GAPS_M = (20e-6, 50e-6, 100e-6, 200e-6)


def capacitance_breakdown(meniscus_gap_m: float) -> dict:
    """The seed's scene (6208, 500 rad/s, 5820 N, ISO VG 68 at 40 C, quasi-static tier) in full
    film with ``meniscus_gap_m``: medians over the run of the bearing's capacitance, of the part
    the balls loaded at both contacts carry and of the rest (unloaded contacts: their gap's
    outside-zone term only), and of the Hertz zones alone, F."""
    from signatelec.engines.lubrication import contact_state

    scene = Scene.from_dict(
        {
            "effects": {"lubrication": True},
            "lubricant": {"meniscus_gap_m": meniscus_gap_m},
            "numerics": {"fidelity": "quasistatic"},
        }
    )
    result = simulate(scene)
    n, z = len(result.signals), scene.bearing.n_balls
    state = contact_state(scene, result.balls, result.signals)
    ci, co = state.capacitance_f["inner"], state.capacitance_f["outer"]
    ball = np.divide(ci * co, ci + co, out=np.zeros((n, z)), where=(ci + co) > 0)
    both = (result.balls["inner_force_n"].to_numpy() > 0) & (
        result.balls["outer_force_n"].to_numpy() > 0
    )
    both = both.reshape(n, z)
    return {
        "meniscus_gap_m": meniscus_gap_m,
        "capacitance_f": float(result.signals["capacitance_f"].median()),
        "loaded_balls_f": float(np.median(np.where(both, ball, 0.0).sum(axis=1))),
        "unloaded_contacts_f": float(np.median(np.where(both, 0.0, ball).sum(axis=1))),
        "hertz_only_f": float(np.median(hertz_only_capacitance_f(result))),
        "loaded_balls": float(np.median(both.sum(axis=1))),
    }


def run_cell(omega_rad_s: float, load_fraction: float, temperature_c: float) -> dict:
    scene = cell_scene(omega_rad_s, load_fraction, temperature_c)
    wet = simulate(scene)
    dry = simulate(scene.with_overrides(lubrication=False))
    b, n, z = wet.balls, len(wet.signals), scene.bearing.n_balls
    lam = np.full((n, 2 * z), np.nan)
    for i, race in enumerate(("inner", "outer")):
        loaded = b[f"{race}_force_n"].to_numpy().reshape(n, z) > 0.0
        values = b[f"{race}_film_parameter"].to_numpy().reshape(n, z)
        lam[:, i * z : (i + 1) * z] = np.where(loaded, values, np.nan)
    lam_min = float(np.median(np.nanmin(lam, axis=1)))
    heaviest = b.loc[b.groupby("time_s")["inner_force_n"].idxmax()]
    signals = wet.signals
    r_wet = float(signals["resistance_ohm"].median())
    r_dry = float(dry.signals["resistance_ohm"].median())
    regime = "boundary" if lam_min < 1.0 else ("mixed" if lam_min <= 3.0 else "full")
    return {
        "omega_rad_s": omega_rad_s,
        "speed_rpm": omega_rad_s / RPM,
        "load_fraction": load_fraction,
        "radial_load_n": scene.operating.radial_load_n,
        "temperature_c": temperature_c,
        "viscosity_pa_s": scene.lubricant.resolved().viscosity_pa_s,
        "lambda_min": lam_min,
        "regime": regime,
        "inner_film_m": float(heaviest["inner_film_m"].median()),
        "outer_film_m": float(heaviest["outer_film_m"].median()),
        "resistance_ohm": r_wet,
        "dry_resistance_ohm": r_dry,
        "dry_model_holds": bool(abs(r_wet / r_dry - 1.0) <= DRY_RTOL),
        "impedance_ohm": float(signals["impedance_ohm"].median()),
        "impedance_phase_rad": float(signals["impedance_phase_rad"].median()),
        "capacitance_f": float(signals["capacitance_f"].median()),
        "hertz_only_capacitance_f": float(np.median(hertz_only_capacitance_f(wet))),
        "measurement_frequency_hz": scene.operating.measurement_frequency_hz,
    }


def run_map(quick: bool = False, log: Callable[[str], None] | None = None) -> pd.DataFrame:
    speeds = speeds_rad_s(4 if quick else N_SPEEDS)
    loads = (0.2,) if quick else LOAD_FRACTIONS
    temperatures = (40.0,) if quick else TEMPERATURES_C
    rows = []
    for t in temperatures:
        for load in loads:
            for omega in speeds:
                rows.append(run_cell(float(omega), load, t))
                if log is not None:
                    r = rows[-1]
                    log(
                        f"{t:g} C, {load:g} C_r, {r['speed_rpm']:.4g} rpm: Lambda "
                        f"{r['lambda_min']:.3g} ({r['regime']}), |Z| {r['impedance_ohm']:.3g} ohm"
                    )
    return pd.DataFrame(rows)


def crossing_rpm(group: pd.DataFrame, column: str, level: float) -> float:
    """Speed (rpm, log-interpolated) at which ``column`` first rises through ``level``."""
    x, y = np.log(group["speed_rpm"].to_numpy()), group[column].to_numpy(dtype=float)
    above = np.flatnonzero(y >= level)
    if above.size == 0:
        return math.nan
    i = above[0]
    if i == 0:
        return float(np.exp(x[0]))
    ly0, ly1 = np.log(y[i - 1]), np.log(y[i])
    return float(np.exp(x[i - 1] + (np.log(level) - ly0) / (ly1 - ly0) * (x[i] - x[i - 1])))


def summary(table: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (t, load), g in table.groupby(["temperature_c", "load_fraction"], sort=True):
        g = g.sort_values("speed_rpm").assign(
            r_ratio=lambda d: d.resistance_ohm / d.dry_resistance_ohm
        )
        rows.append(
            {
                "temperature_c": t,
                "load_fraction": load,
                "dry_holds_below_rpm": crossing_rpm(g, "r_ratio", 1.0 + DRY_RTOL),
                "lambda_1_rpm": crossing_rpm(g, "lambda_min", 1.0),
                "lambda_3_rpm": crossing_rpm(g, "lambda_min", 3.0),
            }
        )
    return pd.DataFrame(rows)


def _rpm(x: float) -> str:
    return "beyond the map" if not np.isfinite(x) else f"{x:.3g}"


def markdown(table: pd.DataFrame, run_time_s: float, breakdown: pd.DataFrame | None = None) -> str:
    s = summary(table)
    seed = table[(table.temperature_c == 40.0) & (table.load_fraction == 0.2)]
    full = seed[seed.regime == "full"]
    lines = [
        "# Lubrication regime map",
        "",
        "The seed's bearing (6208, 2D model) on the quasi-static tier with `effects.lubrication = "
        '"ehl"`, ISO VG 68, from 1 rpm to the 6208\'s limiting speed (11 000 rpm), F_r = '
        f"{', '.join(f'{x:g}' for x in sorted(table.load_fraction.unique()))} C_r, oil at "
        f"{', '.join(f'{x:g}' for x in sorted(table.temperature_c.unique()))} C. Lambda: the "
        "smallest film parameter h_min / sigma of the loaded contacts (sigma = 0.065 um); the dry "
        f"model holds where the lubricated DC resistance is within {100 * DRY_RTOL:g} % of the "
        "seed's dry model. |Z|, phase and capacitance at "
        f"{table.measurement_frequency_hz.iloc[0]:g} Hz. Generated by `signatelec study "
        f"lubrication-regimes` ({len(table)} cells, {run_time_s:.0f} s).",
        "",
        "| oil C | F_r / C_r | dry model holds below (rpm) | Lambda = 1 at (rpm) | "
        "Lambda = 3 at (rpm) |",
        "|---|---|---|---|---|",
    ]
    for r in s.itertuples():
        lines.append(
            f"| {r.temperature_c:g} | {r.load_fraction:g} | {_rpm(r.dry_holds_below_rpm)} | "
            f"{_rpm(r.lambda_1_rpm)} | {_rpm(r.lambda_3_rpm)} |"
        )
    if len(full):
        ratio = full.capacitance_f / full.hertz_only_capacitance_f
        lines += [
            "",
            f"In full film (40 C, 0.2 C_r) the bearing's capacitance is "
            f"{1e12 * full.capacitance_f.min():.0f}-{1e12 * full.capacitance_f.max():.0f} pF, "
            f"{ratio.min():.1f}-{ratio.max():.1f} times what the Hertz zones alone give: the "
            "film outside the Hertz zones and the unloaded balls carry most of it.",
        ]
    if breakdown is not None and len(breakdown):
        lines += [
            "",
            "The full-film capacitance of the seed's scene (500 rad/s, 5820 N, 40 C) in parts, "
            "over the meniscus gap h_m that bounds the film outside the Hertz zones (the model's "
            "default 50 um); medians over the run, pF:",
            "",
            "| h_m um | bearing | loaded balls | unloaded contacts | Hertz zones alone | "
            "loaded balls (count) |",
            "|---|---|---|---|---|---|",
        ]
        for r in breakdown.itertuples():
            lines.append(
                f"| {1e6 * r.meniscus_gap_m:g} | {1e12 * r.capacitance_f:.1f} | "
                f"{1e12 * r.loaded_balls_f:.1f} | {1e12 * r.unloaded_contacts_f:.1f} | "
                f"{1e12 * r.hertz_only_f:.1f} | {r.loaded_balls:g} |"
            )
    lines += [
        "",
        "| oil C | F_r / C_r | rpm | Lambda | regime | R / R_dry | abs Z ohm | phase rad | C pF |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table.itertuples():
        lines.append(
            f"| {r.temperature_c:g} | {r.load_fraction:g} | {r.speed_rpm:.3g} | "
            f"{r.lambda_min:.3g} | {r.regime} | {r.resistance_ohm / r.dry_resistance_ohm:.3g} | "
            f"{r.impedance_ohm:.3g} | {r.impedance_phase_rad:.3f} | {1e12 * r.capacitance_f:.1f} |"
        )
    return "\n".join(lines) + "\n"


def figure(table: pd.DataFrame, path: Path) -> Path:
    fig = new_figure(7.0, 8.0)
    axes = fig.subplots(3, 1, sharex=True)
    styles = {40.0: "-", 70.0: "--", 100.0: ":"}
    for (t, load), g in table.groupby(["temperature_c", "load_fraction"], sort=True):
        g = g.sort_values("speed_rpm")
        label = f"{load:g} C_r, {t:g} C"
        kw = {
            "ls": styles.get(t, "-"),
            "color": f"C{sorted(table.load_fraction.unique()).index(load)}",
        }
        axes[0].loglog(g.speed_rpm, g.lambda_min, label=label, **kw)
        axes[1].loglog(g.speed_rpm, g.impedance_ohm, **kw)
        axes[2].semilogx(g.speed_rpm, g.impedance_phase_rad, **kw)
        holds = g[g.dry_model_holds]
        if len(holds):
            axes[1].loglog(holds.speed_rpm, holds.impedance_ohm, "o", ms=3, color=kw["color"])
    for lam, text in ((1.0, "boundary | mixed"), (3.0, "mixed | full film")):
        axes[0].axhline(lam, color="grey", lw=0.8)
        axes[0].text(1.2, lam * 1.1, text, fontsize=7, color="grey")
    s = summary(table)
    seed = s[(s.temperature_c == 40.0) & (s.load_fraction == 0.2)]
    if len(seed) and np.isfinite(seed.dry_holds_below_rpm.iloc[0]):
        for ax in axes:
            ax.axvspan(LOWEST_RPM, seed.dry_holds_below_rpm.iloc[0], color="tab:green", alpha=0.12)
    axes[0].set_ylabel("smallest Lambda")
    axes[1].set_ylabel("|Z| (ohm)")
    axes[2].set_ylabel("phase (rad)")
    axes[2].set_xlabel("inner-ring speed (rpm)")
    axes[0].legend(fontsize=6, ncol=3)
    axes[0].set_title(
        "seed bearing, ISO VG 68; shaded: the dry model holds (0.2 C_r, 40 C); dots: cells "
        "where it holds",
        fontsize=8,
    )
    return save_figure(fig, path)


#: Speeds of the Bode plot (rpm): boundary, mixed and full film at 40 C, 0.2 C_r; the last is
#: the seed's 500 rad/s.
BODE_RPM = (10.0, 300.0, 500.0 / RPM)


def bode_figure(path: Path) -> Path:
    """|Z| and phase over 10 Hz-10 MHz at one instant of the seed's scene at :data:`BODE_RPM`
    (:func:`signatelec.engines.lubrication.impedance_sweep`)."""
    from signatelec.engines.lubrication import impedance_sweep

    f = np.geomspace(10.0, 1e7, 121)
    fig = new_figure(7.0, 5.0)
    top, bottom = fig.subplots(2, 1, sharex=True)
    for rpm in BODE_RPM:
        sweep = impedance_sweep(simulate(cell_scene(rpm * RPM, 0.2, 40.0)), f, instant=0)
        top.loglog(f, sweep.impedance_ohm, label=f"{rpm:.4g} rpm")
        bottom.semilogx(f, sweep.impedance_phase_rad)
    top.set_ylabel("|Z| (ohm)")
    bottom.set_ylabel("phase (rad)")
    bottom.set_xlabel("frequency (Hz)")
    top.legend(fontsize=7)
    top.set_title("seed bearing, 0.2 C_r, ISO VG 68 at 40 C: one instant", fontsize=8)
    return save_figure(fig, path)


def run_study(out_dir, *, quick: bool = False, log=None) -> dict[str, Path]:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    table = run_map(quick=quick, log=log)
    run_time = time.perf_counter() - t0
    breakdown = pd.DataFrame(
        [capacitance_breakdown(h) for h in (MENISCUS_GAPS_M[1:2] if quick else MENISCUS_GAPS_M)]
    )
    paths = {
        "parquet": out / "lubrication_regimes.parquet",
        "md": out / "lubrication_regimes.md",
        "png": out / "lubrication_regimes.png",
        "bode": out / "bode.png",
    }
    write_bytes_atomic(paths["parquet"], table.to_parquet(index=False))
    write_bytes_atomic(paths["md"], markdown(table, run_time, breakdown).encode("utf-8"))
    figure(table, paths["png"])
    bode_figure(paths["bode"])
    return paths
