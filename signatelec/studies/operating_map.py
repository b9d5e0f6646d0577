"""The operating map: every catalogue bearing at its rated speeds, with nothing but defaults.

Each cell is one bearing of :mod:`signatelec.config.catalogue`, one inner-ring speed (geometric
from :data:`LOWEST_SPEED_RAD_S` to the bearing's limiting speed), one radial load (the bearing's
minimum load at that speed, then :data:`LOAD_FRACTIONS` of C_r) and one clearance (a preload,
zero, or the bearing's normal clearance), for each cage model asked for. The scene keeps every
default: the time step, spin-up and duration it chooses itself
(:func:`signatelec.config.scene.resolve_auto`), except a short steady window (settling, then
:data:`BALL_PASSES` ball passes: the duration follows the ball-pass period) and the energy
balance (``outputs.energy``). A cell records:

- completion (or the divergence message, with its measured cure; or the tier's failure to reach
  the ring's equilibrium, recorded as ``tier failed`` with its message);
- the energy balance: ``|W_in - D - E_el - E_kin| / W_in`` at the end of the run;
- the largest ball/raceway overlap at the recorded instants, as a share of the ball radius (the
  kernel aborts at 10 %);
- the steady state against the quasi-static tier on the same recorded instants: mean resistance
  within :data:`RESISTANCE_RTOL`, mean largest ball load within :data:`LOAD_RTOL`.

The lightest load is the bearing's minimum load (SKF's F_rm,
:func:`signatelec.config.catalogue.minimum_load_n`, with the scene's lubricant): below it a ball
bearing skids, and the tier assumes rolling. At F_r = 0 the ring's and the balls' weights are
the whole load and the ball set slides for seconds; those cells (``cells(zero_load=True)``) are
a check of their own, without the tier (:func:`skid_status`: completion, outputs, energy
balance), written from the cache as ``below_minimum_load.{md,parquet}``; they are run by
:func:`run_map` (the automatic spin-up waits for the traction,
:func:`signatelec.physics.stability.traction_spin_up_time_s`: seconds of bearing time).

Normal clearance: the middle of the group N radial internal clearance of ISO 5753-1:2009
(table 1, deep-groove ball bearings) for the bearing's bore, used as the model's clearance
Delta_r (seed eq. 14). Preload: 5 um, or half the ISO 76 preload limit when that is smaller.

Finished cells are cached in ``OUT/.cache`` under :meth:`Cell.key` (an interrupted map resumes;
``fresh`` starts over; ``cached_only`` writes the outputs from the finished cells, the others
listed as ``not run``).
Writes ``operating_map.parquet``, ``operating_map.md`` and ``operating_map.png``.
"""

from __future__ import annotations

import hashlib
import json
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec._version import __version__
from signatelec.config.bearing import INNER, OUTER
from signatelec.config.catalogue import (
    catalogue_bearing,
    limiting_speed_rad_s,
    list_bearings,
    minimum_load_n,
    rated_entry,
)
from signatelec.config.scene import Scene, SceneError, preload_limit_m
from signatelec.io import write_bytes_atomic
from signatelec.physics.electrical import CurrentDensityWarning
from signatelec.physics.laws import scene_law
from signatelec.studies.operating_map_report import write_outputs, write_skid_outputs

LOWEST_SPEED_RAD_S = 10.0
N_SPEEDS = 5
#: The radial loads above the lightest, as shares of C_r; the lightest is the bearing's minimum
#: load at the cell's speed (:func:`minimum_load_fraction`).
LOAD_FRACTIONS = (0.05, 0.2, 0.5)
#: The cage models mapped: the seed's cage balls and the rigid cage.
CAGES = ("balls", "rigid")
#: Steady running kept after the set-up: settling, then this many outer-race ball passes.
#: The set-up's transient decays over ~20 ms at light load and speed (measured: seed's bearing,
#: 0.05 C_r, zero clearance, 351.6 rad/s: the ball set's speed dips 0.2 % and the ring moves
#: 77 nm rms in the 10-20 ms after the spin-up; mean resistance -1.5 %, then -0.4 %, then
#: within 0.05 % of the tier from 20 ms on).
SETTLE_S = 20e-3
BALL_PASSES = 3
RESISTANCE_RTOL = 0.01
LOAD_RTOL = 0.02
#: Largest energy-balance error a completed cell may show (share of the work put in).
ENERGY_RTOL = 0.01
PRELOAD_M = 5e-6
#: ISO 5753-1:2009 table 1, group N radial internal clearance of deep-groove ball bearings:
#: (bore over, bore up to and including) in mm -> (min, max) in um.
ISO_5753_GROUP_N_UM = {
    (10.0, 18.0): (3.0, 18.0),
    (18.0, 24.0): (5.0, 20.0),
    (24.0, 30.0): (5.0, 20.0),
    (30.0, 40.0): (6.0, 20.0),
    (40.0, 50.0): (6.0, 23.0),
}


def normal_clearance_m(designation: str) -> float:
    """Middle of the ISO 5753-1 group N clearance for the bearing's bore, m."""
    entry = rated_entry(designation)
    bore_mm = entry.bore_diameter_m * 1e3
    for (low, high), (cmin, cmax) in ISO_5753_GROUP_N_UM.items():
        if low < bore_mm <= high:
            return 0.5 * (cmin + cmax) * 1e-6
    raise ValueError(f"bore {bore_mm:g} mm: outside the ISO 5753-1 rows of this study")


def speeds_rad_s(designation: str, n: int = N_SPEEDS) -> np.ndarray:
    return np.geomspace(LOWEST_SPEED_RAD_S, limiting_speed_rad_s(designation), n)


@dataclass(frozen=True)
class Cell:
    designation: str
    omega_rad_s: float
    load_fraction: float
    clearance: str  # "preload", "zero" or "normal"
    cage: str = "balls"

    def key(self, ball_passes: int = BALL_PASSES) -> str:
        """Cache key: the cell, the version, what its scene sets apart from a default ``Scene()``
        and the numerics it chose (:func:`scene_key_values`), so a scene section or field added
        with its default keeps the cache while any value the cell runs with does not."""
        try:
            scene = scene_key_values(cell_scene(self, ball_passes))
        except SceneError as exc:
            scene = str(exc)
        text = json.dumps(asdict(self) | {"version": __version__, "scene": scene}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:20]


def _leaves(tree, prefix: str = "") -> dict:
    if isinstance(tree, dict):
        return {
            k: v for name, sub in tree.items() for k, v in _leaves(sub, f"{prefix}{name}.").items()
        }
    return {prefix[:-1]: tree}


def scene_key_values(scene: Scene) -> dict:
    """The scene's values that differ from a default ``Scene()`` (the bearing's fields
    included), plus its resolved automatic numerics (dt, spin-up, duration), by dotted name.
    A field added to the scene with its default value is absent from both, so it changes no
    key; a changed default value of an existing field is not seen either: that is a change of
    the physics, which bumps the version or asks for ``fresh``."""
    default = _leaves(Scene().to_dict())
    values = _leaves(scene.to_dict())
    key = {k: v for k, v in values.items() if k not in default or default[k] != v}
    for name in ("numerics.dt_s", "procedure.spin_up_time_s", "numerics.duration_s"):
        key[name] = values[name]
    return key


def clearance_m(cell: Cell) -> float:
    if cell.clearance == "zero":
        return 0.0
    if cell.clearance == "normal":
        return normal_clearance_m(cell.designation)
    bearing = catalogue_bearing(cell.designation)
    return -min(PRELOAD_M, 0.5 * preload_limit_m(bearing))


def cell_scene(cell: Cell, ball_passes: int = BALL_PASSES) -> Scene:
    """The cell's scene: defaults, the energy balance on, a short steady window."""
    bearing = catalogue_bearing(cell.designation)
    scene = Scene(bearing=bearing).with_overrides(
        radial_load_n=cell.load_fraction * bearing.dynamic_load_rating_n,
        clearance_m=clearance_m(cell),
        omega_rad_s=cell.omega_rad_s,
        energy=True,
        cage=cell.cage,
    )
    passes_hz = bearing.ball_pass_frequency_hz(cell.omega_rad_s)
    return scene.with_overrides(duration_s=scene.setup_time_s + SETTLE_S + ball_passes / passes_hz)


def minimum_load_fraction(designation: str, omega_rad_s: float) -> float:
    """The bearing's minimum load at ``omega_rad_s`` with the scene's default lubricant
    (:func:`signatelec.config.catalogue.minimum_load_n`), as a share of its C_r."""
    viscosity = Scene().lubricant.kinematic_viscosity_mm2_s()
    bearing = catalogue_bearing(designation)
    return minimum_load_n(designation, viscosity, omega_rad_s) / bearing.dynamic_load_rating_n


def cells(
    designations: Sequence[str] | None = None,
    cages: Sequence[str] = CAGES,
    n_speeds: int = N_SPEEDS,
    zero_load: bool = False,
) -> list[Cell]:
    """The map's cells: at each speed the minimum load and :data:`LOAD_FRACTIONS`
    (``zero_load``: F_r = 0 alone, the cells below the minimum load)."""
    designations = list(designations or list_bearings().index)

    def loads(d, w):
        return (0.0,) if zero_load else (minimum_load_fraction(d, w), *LOAD_FRACTIONS)

    return [
        Cell(d, float(w), f, c, cage)
        for cage in cages
        for d in designations
        for w in speeds_rad_s(d, n_speeds)
        for f in loads(d, float(w))
        for c in ("preload", "zero", "normal")
    ]


#: The quick map: three cells spanning speed, load, clearance and bearing size.
QUICK_CELLS = (
    Cell("seed", 500.0, 0.2, "zero"),
    Cell("6205", float(speeds_rad_s("6205")[-1]), 0.05, "normal"),
    Cell("6308", float(speeds_rad_s("6308")[2]), 0.5, "preload"),
)


def largest_overlap_fraction(scene: Scene, balls: pd.DataFrame) -> float:
    """Largest ball/raceway overlap at the recorded instants / ball radius (inverse of the law)."""
    coef, n = scene_law(scene)
    overlaps = [
        (balls[col].clip(lower=0.0).max() / coef[kind]) ** (1.0 / n)
        for col, kind in (("inner_force_n", INNER), ("outer_force_n", OUTER))
    ]
    return float(max(overlaps) / scene.bearing.ball_radius_m)


def run_cell(cell: Cell, ball_passes: int = BALL_PASSES) -> dict:
    """One cell of the map (see the module docstring), as a flat record."""
    from signatelec.engines.results import DivergenceError
    from signatelec.engines.simulate import simulate

    row = asdict(cell) | {"status": "ok", "message": ""}
    try:
        scene = cell_scene(cell, ball_passes)
    except SceneError as exc:
        return row | {"status": "refused", "message": str(exc)}
    row |= {
        "clearance_m": scene.operating.clearance_m,
        "radial_load_n": scene.operating.radial_load_n,
        "dt_s": scene.numerics.dt_s,
        "spin_up_time_s": scene.procedure.spin_up_time_s,
        "duration_s": scene.numerics.duration_s,
    }
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            dem = simulate(scene)
        except DivergenceError as exc:
            row["run_s"] = time.perf_counter() - t0
            return row | {"status": "diverged", "message": str(exc)}
    row["run_s"] = time.perf_counter() - t0
    row["warnings"] = " | ".join(str(w.message) for w in caught)
    row["current_density_warning"] = any(
        isinstance(w.message, CurrentDensityWarning) for w in caught
    )
    sig = dem.signals
    end = sig.iloc[-1]
    stored = end.dissipated_j + end.elastic_j + end.kinetic_j
    row["energy_error"] = float(abs(end.work_in_j - stored) / max(end.work_in_j, 1e-300))
    row["largest_overlap_fraction"] = largest_overlap_fraction(scene, dem.balls)
    tier_scene = scene.with_overrides(
        fidelity="quasistatic",
        spin_up_time_s=scene.procedure.spin_up_time_s,
        dt_s=scene.numerics.dt_s,
        duration_s=scene.numerics.duration_s,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            tier = simulate(replace(tier_scene, outputs=replace(tier_scene.outputs, energy=False)))
        except (RuntimeError, ValueError) as exc:  # the tier's equilibrium not reached
            return row | {"status": "tier failed", "message": f"{type(exc).__name__}: {exc}"}
    d, q = dem.steady(settle_s=SETTLE_S), tier.steady(settle_s=SETTLE_S)
    row["resistance_error"] = float(d.resistance_ohm.mean() / q.resistance_ohm.mean() - 1.0)
    row["load_error"] = float(d.max_ball_load_n.mean() / q.max_ball_load_n.mean() - 1.0)
    row["mean_resistance_ohm"] = float(d.resistance_ohm.mean())
    row["mean_max_ball_load_n"] = float(d.max_ball_load_n.mean())
    return classify(row)


def other_warnings(row) -> list[str]:
    """The run's warnings but the steady current density's (physics at light load)."""
    text = row.get("warnings")
    caught = [w for w in (text if isinstance(text, str) else "").split(" | ") if w]
    return [w for w in caught if not w.startswith("contact current density")]


def classify(row: dict) -> dict:
    """The status of a completed cell: ``ok``, or ``off:`` and the checks it misses. A steady
    current density above the seed's 0.1 A/mm^2 is physics (small contacts at light load), not
    a numerical fault: it is kept in ``current_density_warning``, apart from the status; any
    other warning counts."""
    if row["status"] in ("diverged", "refused", "tier failed", "not run"):
        return row
    other = other_warnings(row)
    if "current_density_warning" not in row:  # cells cached before the column existed
        row["current_density_warning"] = "contact current density" in (row.get("warnings") or "")
    failed = [
        name
        for name, bad in (
            ("energy", not row["energy_error"] <= ENERGY_RTOL),
            ("resistance", not abs(row["resistance_error"]) <= RESISTANCE_RTOL),
            ("ball load", not abs(row["load_error"]) <= LOAD_RTOL),
            ("warning", bool(other)),
        )
        if bad
    ]
    row["status"] = "off: " + ", ".join(failed) if failed else "ok"
    return row


def run_map(
    todo: Sequence[Cell],
    out_dir: str | Path,
    *,
    ball_passes: int = BALL_PASSES,
    fresh: bool = False,
    cached_only: bool = False,
    log: Callable[[str], None] | None = None,
) -> pd.DataFrame:
    """Run the cells (finished ones from ``OUT/.cache``) and return one row per cell;
    ``cached_only``: run none, a cell not in the cache is ``not run``."""
    cache = Path(out_dir) / ".cache"
    cache.mkdir(parents=True, exist_ok=True)
    rows = []
    for i, cell in enumerate(todo):
        path = cache / f"{cell.key(ball_passes)}-{ball_passes}.json"
        if path.exists() and not fresh:
            row = classify(json.loads(path.read_text()))
        elif cached_only:
            row = asdict(cell) | {"status": "not run", "message": "not in the cache"}
        else:
            row = run_cell(cell, ball_passes)
            write_bytes_atomic(path, json.dumps(row).encode("utf-8"))
        rows.append(row)
        if log is not None:
            log(
                f"[{i + 1}/{len(todo)}] {cell.designation} omega={cell.omega_rad_s:.4g} "
                f"F_r={cell.load_fraction:g} C_r {cell.clearance} {cell.cage}: {row['status']}"
            )
    return pd.DataFrame(rows)


def run_study(
    out_dir: str | Path,
    *,
    quick: bool = False,
    cages: Sequence[str] = CAGES,
    fresh: bool = False,
    cached_only: bool = False,
    log: Callable[[str], None] | None = None,
) -> dict[str, Path]:
    """Run the map (``quick``: :data:`QUICK_CELLS`, two ball passes) and write its outputs
    (``cached_only``: from the finished cells, the others ``not run``)."""
    out = Path(out_dir)
    t0 = time.perf_counter()
    only = {"fresh": fresh, "cached_only": cached_only, "log": log}
    if quick:
        todo = [replace(c, cage=cage) for cage in cages for c in QUICK_CELLS]
        table = run_map(todo, out, ball_passes=2, **only)
    else:
        table = run_map(cells(cages=cages), out, **only)
    criteria = {
        "ball_passes": 2 if quick else BALL_PASSES,
        "energy_rtol": ENERGY_RTOL,
        "resistance_rtol": RESISTANCE_RTOL,
        "load_rtol": LOAD_RTOL,
        "settle_s": SETTLE_S,
    }
    paths = write_outputs(table, out, criteria, time.perf_counter() - t0)
    if not quick:  # the cells below the minimum load that the cache holds: run by run_map
        skids = run_map(cells(cages=cages, zero_load=True), out, cached_only=True)
        paths |= write_skid_outputs(skid_status(skids), out, ENERGY_RTOL)
    return paths


def skid_status(table: pd.DataFrame) -> pd.DataFrame:
    """The status of cells below the minimum load (F_r = 0), where the ball set skids and the
    quasi-static tier, which assumes rolling, is no reference: ``ok`` when the run completed
    without a warning other than the current density, its outputs are not NaN and its energy
    balance closes within :data:`ENERGY_RTOL`; the tier's errors are dropped."""
    out = table.drop(columns=["resistance_error", "load_error"], errors="ignore").copy()
    for i, row in out.iterrows():
        if row.status in ("diverged", "refused", "not run"):
            continue
        other = other_warnings(row)
        values = [
            row.get(c) for c in ("energy_error", "mean_resistance_ohm", "mean_max_ball_load_n")
        ]
        failed = [
            name
            for name, bad in (
                ("energy", not row.energy_error <= ENERGY_RTOL),
                ("NaN output", any(v is None or np.isnan(v) for v in values)),
                ("warning", bool(other)),
            )
            if bad
        ]
        out.loc[i, "status"] = "off: " + ", ".join(failed) if failed else "ok"
    return out
