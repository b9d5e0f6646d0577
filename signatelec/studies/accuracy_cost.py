"""What accuracy costs in time (issue 4): the fidelity ladder against a fine reference.

For each study scene (light load 0.1 C_r, heavy 0.4 C_r, a 10 um preload, zero clearance, a
40 um clearance; omega = 500 rad/s) a **reference** DEM run (velocity Verlet, dt = 1e-8 s, every
seed effect) is compared with each **setting** of the ladder:

- the quasi-static tier (:mod:`signatelec.engines.quasistatic.tier`);
- the DEM with the seed's effects at several dt (1e-8 s up to the stability limit of
  :func:`signatelec.engines.dem.stability.stability_limit`), with velocity Verlet or symplectic
  Euler;
- the DEM with the linear (eq. 3) or Harris (eqs 10-11) contact law instead of Hertz;
- the DEM without gravity (friction, cage and damping cannot go: the balls would not roll);
- the DEM with cage-ball mass scaling: the polyamide cage balls, whose lightness sets the
  stability limit, made heavier (a numerical device: they carry no current and ~1 N), so dt can
  grow to the steel balls' limit;
- the fidelity presets of :mod:`signatelec.engines.fidelity`.

Each run covers the set-up phases, ``SETTLE_S`` for the spin-up transient, then
``N_PERIODS`` ball-pass periods; the comparison window is the part after the settling. Compared
(relative to the reference): the mean resistance, the amplitude of the resistance at the
ball-pass frequency (:func:`ball_pass_amplitude`), the RMS difference of the resistance traces
(the setting's trace interpolated onto the reference's instants), and the largest ball load.
Cost: wall time and CPU time per simulated second of bearing time, compile time excluded;
for the quasi-static tier, per second of the steady phase it returns. The CPU time is the one
compared (cost relative to the paper's setting, Pareto plot): the wall time of a shared machine
also counts the other processes.

Outputs (:func:`run_study`): ``accuracy_cost.parquet`` (one row per scene and setting),
``accuracy_cost.md`` (summary and per-scene tables), ``accuracy_cost.png`` (Pareto plot:
error against cost, log axes). Runs are resumable: finished cases are kept in
``OUT/.cache/`` (``fresh=True`` / ``--fresh`` starts over).
"""

from __future__ import annotations

import json
import math
import os
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.config.scene import Scene

#: NSK basic dynamic load rating of the 6208, N (seed 2.2.2).
DYNAMIC_LOAD_RATING_N = 29100.0
#: Time after the set-up left for the spin-up transient to damp before comparing, s.
SETTLE_S = 2e-3
#: Ball-pass periods compared after the settling (full study; --quick: QUICK_PERIODS).
N_PERIODS = 10
QUICK_PERIODS = 3
#: Time step of the reference runs, s.
REFERENCE_DT_S = 1e-8
#: The paper's setting (seed section 4): the cost every other is compared with.
PAPER_SETTING = "dem verlet dt=1e-7 (paper)"
#: Accuracy asked of a cheaper setting: mean resistance and ball-pass amplitude within 1 %.
TOLERANCE = 0.01


@dataclass(frozen=True)
class StudyScene:
    name: str
    radial_load_n: float
    clearance_m: float


SCENES: tuple[StudyScene, ...] = (
    StudyScene("light 0.1 Cr", 0.1 * DYNAMIC_LOAD_RATING_N, 0.0),
    StudyScene("heavy 0.4 Cr", 0.4 * DYNAMIC_LOAD_RATING_N, 0.0),
    StudyScene("preload -10 um", 0.2 * DYNAMIC_LOAD_RATING_N, -10e-6),
    StudyScene("zero clearance", 0.2 * DYNAMIC_LOAD_RATING_N, 0.0),
    StudyScene("clearance +40 um", 0.2 * DYNAMIC_LOAD_RATING_N, 40e-6),
)


@dataclass(frozen=True)
class Setting:
    """One rung of the ladder: a tier and its numerics/effects, applied to a study scene.

    ``dt_s`` is absolute; ``dt_limit_fraction`` sets dt as a fraction of the scene's stability
    limit instead. ``preset`` applies :func:`signatelec.engines.fidelity.apply_fidelity` (the other
    fields are then ignored).
    """

    name: str
    tier: str = "dem"
    dt_s: float | None = 1e-7
    dt_limit_fraction: float | None = None
    integrator: str = "verlet"
    contact_law: str = "hertz"
    effects: tuple[tuple[str, object], ...] = ()
    cage_mass_scale: float = 1.0
    preset: str | None = None

    def definition(self) -> str:
        """What the setting does (a preset's current bundle included): cached rows must match."""
        text = repr(self)
        if self.preset is not None:
            from signatelec.engines.fidelity import PRESETS

            text += repr(PRESETS.get(self.preset))
        return text

    def scene(self, base: Scene) -> Scene:
        if self.preset is not None:
            from signatelec.engines.fidelity import apply_fidelity

            return apply_fidelity(base, self.preset)
        if self.tier == "quasistatic":
            return base.with_overrides(fidelity="quasistatic")
        from signatelec.engines.fidelity import apply_numerics

        return apply_numerics(
            base,
            cage_mass_scale=self.cage_mass_scale,
            dt_s=self.dt_s,
            dt_limit_fraction=self.dt_limit_fraction,
            integrator=self.integrator,
            contact_law=self.contact_law,
            **dict(self.effects),
        )


REFERENCE = Setting("reference dt=1e-8", dt_s=REFERENCE_DT_S)

SETTINGS: tuple[Setting, ...] = (
    Setting("quasistatic", tier="quasistatic", dt_s=None),
    Setting("dem verlet dt=2e-8", dt_s=2e-8),
    Setting("dem verlet dt=5e-8", dt_s=5e-8),
    Setting(PAPER_SETTING, dt_s=1e-7),
    Setting("dem verlet dt=0.95 limit", dt_s=None, dt_limit_fraction=0.95),
    Setting("dem euler dt=2e-8", dt_s=2e-8, integrator="euler"),
    Setting("dem euler dt=5e-8", dt_s=5e-8, integrator="euler"),
    Setting("dem euler dt=1e-7", dt_s=1e-7, integrator="euler"),
    Setting("dem euler dt=1.5e-7", dt_s=1.5e-7, integrator="euler"),
    Setting("dem euler dt=0.9 limit", dt_s=None, dt_limit_fraction=0.9, integrator="euler"),
    Setting("dem linear law dt=1e-7", dt_s=1e-7, contact_law="linear"),
    Setting(
        "dem linear law dt=0.95 limit", dt_s=None, dt_limit_fraction=0.95, contact_law="linear"
    ),
    Setting("dem harris law dt=1e-7", dt_s=1e-7, contact_law="harris"),
    Setting("dem hertz no gravity dt=1e-7", dt_s=1e-7, effects=(("gravity", "none"),)),
    Setting("dem cage mass x10 dt=0.9 limit", dt_s=None, dt_limit_fraction=0.9, cage_mass_scale=10),
    Setting(
        "dem cage mass x10 euler dt=0.9 limit",
        dt_s=None,
        dt_limit_fraction=0.9,
        cage_mass_scale=10,
        integrator="euler",
    ),
    Setting("dem cage mass x80 dt=5e-7", dt_s=5e-7, cage_mass_scale=80),
    Setting("dem cage mass x80 dt=0.9 limit", dt_s=None, dt_limit_fraction=0.9, cage_mass_scale=80),
    *(
        Setting(
            f"dem cage mass x80 euler dt={fraction} limit",
            dt_s=None,
            dt_limit_fraction=fraction,
            cage_mass_scale=80,
            integrator="euler",
        )
        for fraction in (0.5, 0.75, 0.9)
    ),
    Setting("dem cage mass x80 euler dt=1e-6", dt_s=1e-6, cage_mass_scale=80, integrator="euler"),
)

QUICK_SCENES = (SCENES[3],)
QUICK_SETTINGS = (SETTINGS[0], SETTINGS[2], SETTINGS[3])


# --- pure measures --------------------------------------------------------------------------------


def ball_pass_amplitude(time_s, values, frequency_hz: float) -> float:
    """Amplitude of the component of ``values`` at ``frequency_hz`` (least squares).

    Fits ``a + b (t - t_mean) + c cos(2 pi f t) + d sin(2 pi f t)`` and returns ``hypot(c, d)``:
    the amplitude (half the peak-to-peak) of the fundamental, exact for a sampled sinusoid of
    that frequency whatever the number of periods (no FFT bin leakage; the linear term absorbs a
    slow drift). Same unit as ``values``.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(values, dtype=float)
    if t.shape != y.shape or t.ndim != 1 or t.size < 5:
        raise ValueError("time_s and values: equal 1-D shapes with at least 5 samples expected")
    if not frequency_hz > 0.0:
        raise ValueError(f"frequency_hz = {frequency_hz!r}: must be > 0")
    phase = 2.0 * math.pi * frequency_hz * t
    design = np.column_stack((np.ones_like(t), t - t.mean(), np.cos(phase), np.sin(phase)))
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    return float(math.hypot(coef[2], coef[3]))


def rms_difference(time_s, values, reference_time_s, reference_values) -> float:
    """RMS of ``values`` (linearly interpolated onto the reference instants) minus the reference.

    Reference instants outside ``time_s`` are left out.
    """
    t, y = np.asarray(time_s, dtype=float), np.asarray(values, dtype=float)
    tr, yr = np.asarray(reference_time_s, dtype=float), np.asarray(reference_values, dtype=float)
    inside = (tr >= t[0]) & (tr <= t[-1])
    diff = np.interp(tr[inside], t, y) - yr[inside]
    return float(np.sqrt(np.mean(diff * diff)))


@dataclass(frozen=True)
class Trace:
    """The compared part of a run: the steady window after the settling."""

    time_s: np.ndarray
    resistance_ohm: np.ndarray
    max_ball_load_n: np.ndarray
    ball_pass_frequency_hz: float

    @classmethod
    def of(cls, result, window_start_s: float) -> Trace:
        sig = result.signals
        sig = sig[sig["time_s"] > window_start_s]
        z = result.scene.bearing.n_balls
        # the run's own ball-pass frequency, from its mean cage speed (slip lowers it a little)
        frequency = z * float(sig["cage_speed_rad_s"].mean()) / (2.0 * math.pi)
        return cls(
            sig["time_s"].to_numpy(),
            sig["resistance_ohm"].to_numpy(),
            sig["max_ball_load_n"].to_numpy(),
            frequency,
        )

    def measures(self) -> dict:
        return {
            "mean_resistance_ohm": float(self.resistance_ohm.mean()),
            "ball_pass_amplitude_ohm": ball_pass_amplitude(
                self.time_s, self.resistance_ohm, self.ball_pass_frequency_hz
            ),
            "max_ball_load_n": float(self.max_ball_load_n.max()),
            "ball_pass_frequency_hz": self.ball_pass_frequency_hz,
        }


def compare(trace: Trace, reference: Trace) -> dict:
    """Relative errors of a run against the reference (signed, except the RMS)."""
    m, r = trace.measures(), reference.measures()
    mean = r["mean_resistance_ohm"]
    return {
        **m,
        "mean_resistance_error": m["mean_resistance_ohm"] / mean - 1.0,
        "ball_pass_amplitude_error": m["ball_pass_amplitude_ohm"] / r["ball_pass_amplitude_ohm"]
        - 1.0,
        "rms_resistance_error": rms_difference(
            trace.time_s, trace.resistance_ohm, reference.time_s, reference.resistance_ohm
        )
        / mean,
        "max_ball_load_error": m["max_ball_load_n"] / r["max_ball_load_n"] - 1.0,
    }


# --- runs -----------------------------------------------------------------------------------------


@dataclass
class StudyConfig:
    quick: bool = False
    scenes: Sequence[StudyScene] = field(default_factory=lambda: SCENES)
    settings: Sequence[Setting] = field(default_factory=lambda: SETTINGS)
    n_periods: int = N_PERIODS
    omega_rad_s: float = 500.0

    @classmethod
    def make(cls, quick: bool = False) -> StudyConfig:
        if quick:
            return cls(True, QUICK_SCENES, QUICK_SETTINGS, QUICK_PERIODS)
        return cls(settings=with_presets(SETTINGS))

    def key(self) -> str:
        return json.dumps(
            {
                "scenes": [asdict(s) for s in self.scenes],
                "n_periods": self.n_periods,
                "omega_rad_s": self.omega_rad_s,
                "reference_dt_s": REFERENCE_DT_S,
                "settle_s": SETTLE_S,
            },
            sort_keys=True,
        )


def base_scene(study_scene: StudyScene, config: StudyConfig) -> Scene:
    """The study scene at the reference's numerics: set-up, settling, N ball-pass periods."""
    scene = Scene().with_overrides(
        radial_load_n=study_scene.radial_load_n,
        clearance_m=study_scene.clearance_m,
        omega_rad_s=config.omega_rad_s,
    )
    bpf = scene.bearing.ball_pass_frequency_hz(config.omega_rad_s)
    duration = scene.setup_time_s + SETTLE_S + config.n_periods / bpf
    return scene.with_overrides(duration_s=duration, dt_s=REFERENCE_DT_S)


_WARM: set = set()


def _warm_up(scene: Scene) -> None:
    """Load (or compile) the scene's kernel, or the quasi-static tier, before it is timed."""
    from signatelec.engines.dem.spec import KernelSpec
    from signatelec.engines.dem.stability import stability_limit
    from signatelec.engines.simulate import simulate

    quasistatic = scene.numerics.fidelity == "quasistatic"
    key = "quasistatic" if quasistatic else KernelSpec.from_scene(scene)
    if key in _WARM:
        return
    if quasistatic:
        simulate(scene)
    else:  # a few steps past the set-up, at a coarse dt: same kernel, negligible cost
        dt = 0.5 * stability_limit(scene).dt_limit_s
        fs = scene.numerics.sample_rate_hz
        simulate(scene.with_overrides(dt_s=dt, duration_s=scene.setup_time_s + 2.0 / fs))
    _WARM.add(key)


def run_case(scene: Scene) -> tuple[object, dict]:
    """Simulate a scene; returns the result and its cost (kernel compile/load excluded)."""
    from signatelec.engines.simulate import simulate
    from signatelec.physics.electrical import CurrentDensityWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CurrentDensityWarning)
        _warm_up(scene)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        result = simulate(scene)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    compile_s = result.timings.get("compile_s", 0.0)
    if scene.numerics.fidelity == "quasistatic":
        from signatelec.engines.results import phase_times

        bearing_time = scene.numerics.duration_s - phase_times(scene)[2]
    else:
        bearing_time = scene.numerics.duration_s
    wall, cpu = max(wall - compile_s, 0.0), max(cpu - compile_s, 0.0)
    return result, {
        "wall_s": wall,
        "cpu_s": cpu,
        "compile_s": compile_s,
        "bearing_time_s": bearing_time,
        "wall_s_per_simulated_s": wall / bearing_time,
        "cpu_s_per_simulated_s": cpu / bearing_time,
        "n_steps": int(result.timings.get("n_steps", 0)),
    }


def _setting_columns(setting: Setting, scene: Scene) -> dict:
    from signatelec.engines.dem.stability import stability_limit
    from signatelec.engines.fidelity import cage_mass_scale

    nu, e = scene.numerics, scene.effects
    dem = nu.fidelity == "dem"
    limit = stability_limit(scene).dt_limit_s if dem else math.nan
    scale = cage_mass_scale(scene)
    return {
        "setting": setting.name,
        "tier": nu.fidelity,
        "integrator": nu.integrator if dem else "",
        "contact_law": e.contact_law,
        "gravity": e.gravity == "standard",
        "cage_mass_scale": round(scale, 6),
        "dt_s": nu.dt_s if dem else math.nan,
        "stability_limit_s": limit,
        "dt_over_limit": nu.dt_s / limit if dem else math.nan,
    }


class _Cache:
    """Finished cases in OUT/.cache: an interrupted or extended study resumes from them.

    Rows are keyed by (scene, setting name) and valid for one study configuration
    (:meth:`StudyConfig.key`); a different configuration, or ``fresh``, empties the cache.
    """

    def __init__(self, out: Path, key: str, fresh: bool = False):
        self.dir = out / ".cache"
        self.rows_path = self.dir / "rows.jsonl"
        self.rows: dict[tuple[str, str], dict] = {}
        key_path = self.dir / "key.json"
        valid = key_path.exists() and key_path.read_text() == key and self.rows_path.exists()
        if valid and not fresh:
            for line in self.rows_path.read_text().splitlines():
                if line.strip():
                    row = json.loads(line)
                    self.rows[(row["scene"], row["setting"])] = row
        else:
            self.dir.mkdir(parents=True, exist_ok=True)
            for stale in self.dir.iterdir():
                stale.unlink()
            key_path.write_text(key)

    def _reference_path(self, scene_name: str) -> Path:
        return self.dir / f"reference_{''.join(c if c.isalnum() else '_' for c in scene_name)}.npz"

    def reference(self, scene_name: str) -> Trace | None:
        path = self._reference_path(scene_name)
        if not path.exists():
            return None
        with np.load(path) as data:
            return Trace(
                data["time_s"],
                data["resistance_ohm"],
                data["max_ball_load_n"],
                float(data["ball_pass_frequency_hz"]),
            )

    def save_reference(self, scene_name: str, trace: Trace) -> None:
        path = self._reference_path(scene_name)
        tmp = path.with_name(f".{path.stem}.tmp.npz")
        np.savez(tmp, **asdict(trace))
        os.replace(tmp, path)

    def add(self, row: dict) -> None:
        self.rows[(row["scene"], row["setting"])] = row
        with self.rows_path.open("a") as fh:
            fh.write(json.dumps(row) + "\n")


def run_cases(
    config: StudyConfig, out: Path, progress: bool = True, fresh: bool = False
) -> pd.DataFrame:
    """Every scene's reference, then every setting; finished cases are taken from OUT/.cache."""
    from signatelec.config.scene import SceneError
    from signatelec.engines.results import DivergenceError

    cache = _Cache(out, config.key(), fresh)
    cases = [(s, st) for s in config.scenes for st in (REFERENCE, *config.settings)]
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(cases), desc="accuracy-cost", unit="case")
    for study_scene, setting in cases:
        if bar is not None:
            bar.set_postfix_str(f"{study_scene.name}: {setting.name}"[:60])
        cached = cache.rows.get((study_scene.name, setting.name))
        done = cached is not None and cached.get("definition") == setting.definition()
        if setting is REFERENCE:
            done = done and cache.reference(study_scene.name) is not None
        if not done:
            t0 = time.perf_counter()
            base = base_scene(study_scene, config)
            window = base.setup_time_s + SETTLE_S
            row = {
                "scene": study_scene.name,
                "setting": setting.name,
                "definition": setting.definition(),
            }
            try:
                scene = setting.scene(base)
                row.update(_setting_columns(setting, scene))
                result, cost = run_case(scene)
            except (DivergenceError, SceneError) as exc:
                row["status"] = f"failed: {exc}"
            else:
                trace = Trace.of(result, window)
                if setting is REFERENCE:
                    cache.save_reference(study_scene.name, trace)
                reference = cache.reference(study_scene.name)
                if reference is None:
                    row["status"] = "failed: no reference run"
                else:
                    row.update({"status": "ok", **cost, **compare(trace, reference)})
            row["case_s"] = time.perf_counter() - t0
            cache.add(row)
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    table = pd.DataFrame([cache.rows[(s.name, st.name)] for s, st in cases])
    paper = table[(table["setting"] == PAPER_SETTING) & (table["status"] == "ok")]
    if len(paper):
        paper = paper.set_index("scene")
        for column in ("wall", "cpu"):
            base = table["scene"].map(paper[f"{column}_s_per_simulated_s"])
            name = "cost_vs_paper" if column == "wall" else "cpu_cost_vs_paper"
            table[name] = table[f"{column}_s_per_simulated_s"] / base
    return table


# --- summary, Markdown, plot ----------------------------------------------------------------------


def summarise(table: pd.DataFrame) -> pd.DataFrame:
    """One row per setting: worst |error| over the scenes, median cost."""
    ok = table[table["status"] == "ok"].copy()
    ok["accuracy_error"] = np.maximum(
        ok["mean_resistance_error"].abs(), ok["ball_pass_amplitude_error"].abs()
    )
    agg = {
        "mean_resistance_error": lambda s: s.abs().max(),
        "ball_pass_amplitude_error": lambda s: s.abs().max(),
        "accuracy_error": "max",
        "rms_resistance_error": "max",
        "max_ball_load_error": lambda s: s.abs().max(),
        "wall_s_per_simulated_s": "median",
        "cpu_s_per_simulated_s": "median",
        "dt_over_limit": "median",
    }
    for column in ("cost_vs_paper", "cpu_cost_vs_paper"):
        if column in ok:
            agg[column] = "median"
    summary = ok.groupby("setting", sort=False).agg(agg)
    summary["scenes"] = ok.groupby("setting", sort=False).size()
    failed = table[table["status"] != "ok"].groupby("setting", sort=False).size()
    summary["failed"] = failed.reindex(summary.index).fillna(0).astype(int)
    return summary.reset_index()


def _pct(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{100 * x:.3g} %"


def _num(x: float, fmt: str = ".3g") -> str:
    return "-" if not np.isfinite(x) else format(x, fmt)


def cheap_and_accurate(summary: pd.DataFrame) -> pd.DataFrame:
    """DEM settings within TOLERANCE on mean R and ball-pass amplitude at <= 1/10 of the paper's
    CPU cost (medians over the scenes), the question of issue 4."""
    dem = summary[~summary["setting"].isin(["quasistatic"])]
    return dem[(dem["accuracy_error"] <= TOLERANCE) & (dem["cpu_cost_vs_paper"] <= 0.1)]


def markdown(table: pd.DataFrame, run_time_s: float | None = None) -> str:
    summary = summarise(table)
    lines = [
        "# Accuracy against cost",
        "",
        "Reference: DEM, velocity Verlet, dt = 1e-8 s, every seed effect. Errors are relative to "
        "it, the worst |error| over the scenes; `accuracy` is the larger of the mean resistance "
        "and ball-pass amplitude errors. Costs are medians over the scenes of the time per "
        "simulated second of bearing time (compile excluded; the quasi-static tier: per second "
        "of the steady phase it returns), as wall time and as CPU time of the process; `cost vs "
        "paper` is the CPU time relative to the paper's setting (dt = 1e-7 s, Verlet, every "
        "effect) on the same scene, the steadier measure on a shared machine.",
        "",
        "| setting | mean R | ball-pass amp. | accuracy | RMS trace | max ball load | "
        "wall s / sim. s | CPU s / sim. s | cost vs paper | scenes |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary.itertuples():
        lines.append(
            f"| {r.setting} | {_pct(r.mean_resistance_error)} | "
            f"{_pct(r.ball_pass_amplitude_error)} | {_pct(r.accuracy_error)} | "
            f"{_pct(r.rms_resistance_error)} | {_pct(r.max_ball_load_error)} | "
            f"{_num(r.wall_s_per_simulated_s)} | {_num(r.cpu_s_per_simulated_s)} | "
            f"{_num(getattr(r, 'cpu_cost_vs_paper', math.nan))} | "
            f"{r.scenes}{f' ({r.failed} failed)' if r.failed else ''} |"
        )
    if "cpu_cost_vs_paper" in summary:
        found = cheap_and_accurate(summary)
        names = ", ".join(f"`{n}`" for n in found["setting"]) or "none"
        lines += [
            "",
            f"DEM settings within {100 * TOLERANCE:g} % on mean R and ball-pass amplitude at "
            f"<= 1/10 of the paper's cost: {names}.",
        ]
    lines += [
        "",
        "## Per scene",
        "",
        "| scene | setting | dt (s) | dt / limit | mean R (mOhm) | mean R err | ball-pass amp. "
        "(uOhm) | amp. err | RMS err | max load (N) | load err | wall s / sim. s | "
        "CPU s / sim. s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table.itertuples():
        if r.status != "ok":
            lines.append(f"| {r.scene} | {r.setting} | | | {r.status} | | | | | | | | |")
            continue
        lines.append(
            f"| {r.scene} | {r.setting} | {_num(r.dt_s)} | {_num(r.dt_over_limit, '.2f')} | "
            f"{1e3 * r.mean_resistance_ohm:.5f} | {_pct(r.mean_resistance_error)} | "
            f"{1e6 * r.ball_pass_amplitude_ohm:.4g} | {_pct(r.ball_pass_amplitude_error)} | "
            f"{_pct(r.rms_resistance_error)} | {r.max_ball_load_n:.1f} | "
            f"{_pct(r.max_ball_load_error)} | {_num(r.wall_s_per_simulated_s)} | "
            f"{_num(r.cpu_s_per_simulated_s)} |"
        )
    if run_time_s is not None:
        lines += ["", f"Study run time: {run_time_s:.0f} s (sum of the cases' wall times)."]
    return "\n".join(lines) + "\n"


def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both cost and error, by cost."""
    order = np.argsort(cost, kind="stable")
    front, best = [], math.inf
    for i in order:
        if error[i] < best:
            front.append(i)
            best = error[i]
    return np.array(front, dtype=int)


_FAMILIES = (
    ("quasistatic", "quasi-static tier", "tab:purple"),
    ("preset", "preset", "tab:red"),
    ("cage mass", "DEM, cage mass scaled", "tab:orange"),
    ("euler", "DEM, symplectic Euler", "tab:olive"),
    ("law", "DEM, linear / Harris law", "tab:cyan"),
    ("gravity", "DEM, no gravity", "tab:brown"),
    ("", "DEM, velocity Verlet", "tab:blue"),
)


def _family(setting: str) -> tuple[str, str]:
    for key, label, colour in _FAMILIES:
        if key in setting:
            return label, colour
    raise AssertionError(setting)  # pragma: no cover - the last family matches everything


def plot(table: pd.DataFrame, path: Path) -> None:
    """Pareto plot: worst accuracy error (and RMS trace error) against CPU cost, log axes.

    Points are coloured by family; the Pareto front, the presets, the paper's setting and the
    quasi-static tier are labelled (errors of 0, the reference's, are drawn at 1e-6).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    summary = summarise(table)
    cost = summary["cpu_s_per_simulated_s"].to_numpy()
    names = [n.removeprefix("dem ") for n in summary["setting"]]
    families = [_family(s) for s in summary["setting"]]
    fig = Figure(figsize=(13, 5.6), layout="constrained")
    FigureCanvasAgg(fig)
    panels = (
        ("accuracy_error", "worst |error| of mean R and ball-pass amplitude"),
        ("rms_resistance_error", "worst RMS trace difference / mean R"),
    )
    paper = summary[summary["setting"] == PAPER_SETTING]
    for ax, (column, label) in zip(fig.subplots(1, 2), panels, strict=True):
        error = np.maximum(summary[column].to_numpy(), 1e-6)
        ax.scatter(cost, error, c=[c for _, c in families], s=32, zorder=3)
        front = pareto_front(cost, error)
        ax.plot(cost[front], error[front], "k--", lw=0.8, zorder=2)
        keep = set(front.tolist()) | {
            i
            for i, s in enumerate(summary["setting"])
            if s.startswith(("preset", "quasistatic")) or s == PAPER_SETTING
        }
        for k, i in enumerate(sorted(keep, key=lambda i: cost[i])):
            ax.annotate(
                names[i],
                (cost[i], error[i]),
                fontsize=6.5,
                xytext=(4, 6 if k % 2 else -9),
                textcoords="offset points",
            )
        ax.axhline(TOLERANCE, color="tab:red", lw=0.8, ls=":")
        if len(paper):
            ax.axvline(
                float(paper["cpu_s_per_simulated_s"].iloc[0]) / 10.0,
                color="tab:green",
                lw=0.8,
                ls=":",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU time per simulated second (s/s, median over scenes)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    handles = [
        Line2D([], [], ls="", marker="o", color=colour, label=label)
        for _, label, colour in _FAMILIES
    ] + [
        Line2D([], [], color="k", ls="--", lw=0.8, label="Pareto front"),
        Line2D([], [], color="tab:red", ls=":", lw=0.8, label="1 %"),
        Line2D([], [], color="tab:green", ls=":", lw=0.8, label="1/10 of the paper's cost"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=5, fontsize=7.5)
    fig.suptitle(
        "signatelec: accuracy against cost (5 scenes; reference: DEM, Verlet, dt = 1e-8 s)",
        fontsize=10,
    )
    tmp = path.with_name(f".{path.name}.tmp")
    fig.savefig(tmp, dpi=100, format="png")
    os.replace(tmp, path)


def run_study(
    out_dir: str | Path,
    quick: bool = False,
    progress: bool = True,
    fresh: bool = False,
    config: StudyConfig | None = None,
    log: Callable[[str], None] | None = print,
) -> dict[str, Path]:
    """Run the study into ``out_dir``; returns the paths of the table, the Markdown and the plot.

    Finished cases are kept in ``out_dir/.cache`` (resume; ``fresh`` starts over). The study's
    run time written in the Markdown is the sum of its cases' times, whatever the resumptions.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    config = config or StudyConfig.make(quick)
    t0 = time.perf_counter()
    table = run_cases(config, out, progress=progress, fresh=fresh)
    elapsed = time.perf_counter() - t0
    run_time = float(table["case_s"].sum())
    paths = {
        "table": out / "accuracy_cost.parquet",
        "markdown": out / "accuracy_cost.md",
        "plot": out / "accuracy_cost.png",
    }
    tmp = paths["table"].with_name(".accuracy_cost.parquet.tmp")
    table.to_parquet(tmp, index=False)
    os.replace(tmp, paths["table"])
    tmp = paths["markdown"].with_name(".accuracy_cost.md.tmp")
    tmp.write_text(markdown(table, run_time))
    os.replace(tmp, paths["markdown"])
    plot(table, paths["plot"])
    if log is not None:
        log(f"study run time {run_time:.0f} s (this invocation {elapsed:.0f} s)")
        for path in paths.values():
            log(f"wrote {path}")
    return paths


def with_presets(settings: Sequence[Setting]) -> tuple[Setting, ...]:
    """The settings followed by one per fidelity preset."""
    from signatelec.engines.fidelity import PRESETS

    return (*settings, *(Setting(f"preset {name}", preset=name) for name in PRESETS))
