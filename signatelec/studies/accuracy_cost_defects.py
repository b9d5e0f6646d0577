"""The accuracy-cost study's defect rows: the quasi-static tier against the DEM on spalled
scenes, to say where the tier suffices for a defect's signature and where the impacts need the
DEM.

Both tiers see the same geometry (:mod:`signatelec.config.defects`: a rectangular spall on the
outer race in the load direction, on the inner race, or on ball 0; the tier raises each ball's
clearance by the drop of the spall under its contacts, :mod:`signatelec.engines.quasistatic.
tier`), but only the DEM has the ball's fall into the spall, its impact on the trailing edge
and the rattling after it (Sawalhi and Randall, MSSP 22 (2008) 1924-1951). Each scene (0.2 C_r,
zero clearance, 500 rad/s, a 50 um deep spall) runs with the tier and with the DEM at the
paper's fidelity (velocity Verlet, dt = 1e-7 s, every effect: the reference of these rows, a
tenth of the cost of the study's 1e-8 s reference, which the healthy rows show within 0.1 % of
it) over :data:`CAGE_REVOLUTIONS` cage revolutions after :data:`SETTLE_S` of settling. Compared
(the tier relative to the DEM):

- the mean resistance;
- the event depth: the largest departure of the resistance from its median, relative to the
  median (a ball losing its contact over the spall: the resistance jumps);
- the amplitude of the defect's characteristic line in the resistance (BPFO, BPFI or 2 BSF,
  :func:`signatelec.physics.kinematics.characteristic_frequencies_hz`; least squares at the
  frequency, :func:`signatelec.studies.accuracy_metrics.ball_pass_amplitude`).

The tier *suffices* for a scene when each of the three is within :data:`SUFFICES` of the DEM.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.config.defects import Defect
from signatelec.config.scene import Scene
from signatelec.io import write_bytes_atomic
from signatelec.studies.accuracy_metrics import ball_pass_amplitude

#: Steady time after the set-up before the comparison window, s.
SETTLE_S = 5e-3
#: Cage revolutions compared (a ball's spall is in the load zone once per revolution).
CAGE_REVOLUTIONS = 2.0
QUICK_CAGE_REVOLUTIONS = 0.5
#: Scene of every row: F_r / C_r, clearance, speed, spall depth.
LOAD_FRACTION, CLEARANCE_M, OMEGA_RAD_S, DEPTH_M = 0.2, 0.0, 500.0, 50e-6
#: The tier suffices when the mean resistance, the event depth and the line amplitude are all
#: within this share of the DEM's.
SUFFICES = 0.1
#: The characteristic line of each spall's location.
LINE_OF = {"outer": "bpfo", "inner": "bpfi", "ball": "ball_defect"}


@dataclass(frozen=True)
class DefectScene:
    """A spalled study scene: the spall's location and its length along the surface."""

    name: str
    location: str
    length_m: float


DEFECT_SCENES = (
    DefectScene("outer 0.5 mm", "outer", 0.5e-3),
    DefectScene("outer 2 mm", "outer", 2e-3),
    DefectScene("inner 2 mm", "inner", 2e-3),
    DefectScene("ball 2 mm", "ball", 2e-3),
)
QUICK_SCENES = (DEFECT_SCENES[1],)


def defect_scene(ds: DefectScene, revolutions: float) -> Scene:
    """The spalled scene at the paper's fidelity, long enough for the window."""
    from signatelec.physics.kinematics import characteristic_frequencies_hz

    base = Scene()
    scene = base.with_overrides(
        radial_load_n=LOAD_FRACTION * base.bearing.dynamic_load_rating_n,
        clearance_m=CLEARANCE_M,
        omega_rad_s=OMEGA_RAD_S,
    )
    scene = replace(
        scene,
        defects=(
            Defect(location=ds.location, angle_rad=0.0, length_m=ds.length_m, depth_m=DEPTH_M),
        ),
    )
    ftf = characteristic_frequencies_hz(OMEGA_RAD_S, scene.bearing)["ftf"]
    return scene.with_overrides(duration_s=scene.setup_time_s + SETTLE_S + revolutions / ftf)


def measures(result, ds: DefectScene) -> dict:
    """Mean resistance, event depth and characteristic-line amplitude of a run's window."""
    from signatelec.physics.kinematics import characteristic_frequencies_hz

    scene = result.scene
    sig = result.signals
    sig = sig[sig["time_s"] > scene.setup_time_s + SETTLE_S]
    t, r = sig["time_s"].to_numpy(), sig["resistance_ohm"].to_numpy()
    median = float(np.median(r))
    f = characteristic_frequencies_hz(scene.operating.omega_rad_s, scene.bearing)[
        LINE_OF[ds.location]
    ]
    return {
        "mean_resistance_ohm": float(r.mean()),
        "event_depth": float(np.max(np.abs(r - median)) / median),
        "line_hz": f,
        "line_amplitude_ohm": ball_pass_amplitude(t, r, f),
    }


def run_rows(quick: bool = False, log=None) -> pd.DataFrame:
    """One row per scene: both tiers' measures and cost, the tier's errors, the verdict."""
    from signatelec.engines.fidelity import apply_fidelity
    from signatelec.engines.simulate import simulate
    from signatelec.physics.electrical import CurrentDensityWarning

    rows = []
    revolutions = QUICK_CAGE_REVOLUTIONS if quick else CAGE_REVOLUTIONS
    for ds in QUICK_SCENES if quick else DEFECT_SCENES:
        scene = defect_scene(ds, revolutions)
        row = {"scene": ds.name, "location": ds.location, "spall_length_m": ds.length_m}
        for tier, fidelity in (("quasistatic", "quasistatic"), ("dem", "dem")):
            s = apply_fidelity(scene, fidelity)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", CurrentDensityWarning)
                simulate(s.with_overrides(duration_s=s.setup_time_s + 1e-4))  # compile/load
                cpu0 = time.process_time()
                result = simulate(s)
                cpu = time.process_time() - cpu0
            window = scene.numerics.duration_s - scene.setup_time_s - SETTLE_S
            row |= {f"{tier}_{k}": v for k, v in measures(result, ds).items()}
            row[f"{tier}_cpu_s_per_simulated_s"] = cpu / window
        for k in ("mean_resistance_ohm", "event_depth", "line_amplitude_ohm"):
            row[f"{k}_error"] = row[f"quasistatic_{k}"] / row[f"dem_{k}"] - 1.0
        errors = [abs(row[f"{k}_error"]) for k in ("mean_resistance_ohm", "event_depth")]
        errors.append(abs(row["line_amplitude_ohm_error"]))
        row["tier_suffices"] = bool(max(errors) <= SUFFICES)
        if log is not None:
            log(f"defect rows: {ds.name} done")
        rows.append(row)
    return pd.DataFrame(rows)


def markdown(rows: pd.DataFrame, revolutions: float = CAGE_REVOLUTIONS) -> str:
    """The defect rows' section of the accuracy-cost report."""
    lines = [
        "## Defects: the quasi-static tier against the DEM on spalled scenes",
        "",
        f"0.2 C_r, zero clearance, 500 rad/s, 50 um deep rectangular spalls; "
        f"{revolutions:g} cage revolutions compared after {SETTLE_S * 1e3:g} ms of "
        "settling; the DEM at the paper's fidelity (dt = 1e-7 s) is the reference of these rows. "
        "Errors of the tier relative to the DEM; *event depth*: the largest departure of the "
        "resistance from its median, over the median; *line*: the amplitude of the spall's "
        f"characteristic line (BPFO, BPFI, 2 BSF). The tier suffices within {SUFFICES:.0%}.",
        "",
        "| scene | mean R | event depth DEM / tier | line DEM / tier (uOhm) | errors: mean R, "
        "depth, line | CPU s per s, tier / DEM | tier suffices |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows.itertuples():
        lines.append(
            f"| {r.scene} | {r.dem_mean_resistance_ohm * 1e3:.4f} mOhm | "
            f"{r.dem_event_depth:.2%} / {r.quasistatic_event_depth:.2%} | "
            f"{r.dem_line_amplitude_ohm * 1e6:.3g} / "
            f"{r.quasistatic_line_amplitude_ohm * 1e6:.3g} | "
            f"{r.mean_resistance_ohm_error:+.2%}, {r.event_depth_error:+.0%}, "
            f"{r.line_amplitude_ohm_error:+.0%} | {r.quasistatic_cpu_s_per_simulated_s:.3g} / "
            f"{r.dem_cpu_s_per_simulated_s:.3g} | {'yes' if r.tier_suffices else 'no'} |"
        )
    mean = rows["mean_resistance_ohm_error"].abs().max()
    line = rows["line_amplitude_ohm_error"].abs()
    depth = rows["event_depth_error"]
    lines += [
        "",
        f"Where the tier suffices: the mean resistance (within {mean:.2%} of the DEM on every "
        "scene: the static load sharing with the spall's clearance) and, roughly, the "
        f"characteristic line ({line.min():.0%}-{line.max():.0%} off). Where the impacts need the "
        f"DEM: the events themselves, {-depth.max():.0%}-{-depth.min():.0%} shallower in the "
        "tier, which has no fall of the ball into the spall, no impact on its trailing edge and "
        "no rattling; a detector trained on event shapes (kurtosis, crest factor, envelope "
        "lines) learns from DEM runs.",
    ]
    return "\n".join([*lines, ""])


def document(rows: pd.DataFrame, revolutions: float, cpu_s: float) -> str:
    """``accuracy_cost_defects.md``: a title, where it comes from, the rows' section."""
    return (
        "# Accuracy and cost: defects\n\nWritten by `signatelec study accuracy-cost --defects` "
        f"(signatelec/studies/accuracy_cost_defects.py); {cpu_s:.0f} s of CPU for "
        f"{len(rows)} scenes.\n\n" + markdown(rows, revolutions)
    )


def write_rows(out: Path, quick: bool = False, log=None) -> dict[str, Path]:
    """Run the defect rows and write ``accuracy_cost_defects.{parquet,md}`` into ``out``."""
    cpu0 = time.process_time()
    rows = run_rows(quick, log)
    cpu_s = time.process_time() - cpu0
    paths = {
        "defects_table": out / "accuracy_cost_defects.parquet",
        "defects_markdown": out / "accuracy_cost_defects.md",
    }
    write_bytes_atomic(paths["defects_table"], rows.to_parquet(index=False))
    revolutions = QUICK_CAGE_REVOLUTIONS if quick else CAGE_REVOLUTIONS
    text = document(rows, revolutions, cpu_s)
    write_bytes_atomic(paths["defects_markdown"], text.encode("utf-8"))
    return paths
