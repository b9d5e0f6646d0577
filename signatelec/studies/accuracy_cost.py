"""What accuracy costs in time: the fidelity ladder against a fine reference.

For each study scene (light load 0.1 C_r, heavy 0.4 C_r, a 10 um preload, zero clearance, a
40 um clearance; omega = 500 rad/s) a **reference** DEM run (velocity Verlet, dt = 1e-8 s, every
seed effect) is compared with each **setting** of the ladder:

- the quasi-static tier (:mod:`signatelec.engines.quasistatic.tier`);
- the DEM with the seed's effects at several dt (1e-8 s up to the stability limit of
  :func:`signatelec.physics.stability.stability_limit`), with velocity Verlet or symplectic
  Euler;
- the DEM with the linear (eq. 3) or Harris (eqs 10-11) contact law instead of Hertz;
- the DEM without gravity (friction, cage and damping cannot go: the balls would not roll);
- the DEM with cage-ball mass scaling: the polyamide cage balls, whose lightness sets the
  stability limit, made heavier (a numerical device: they carry no current and ~1 N), so dt can
  grow to the steel balls' limit;
- the DEM with the rigid cage (``effects.cage = "rigid"``, a 7 g PA66-GF25 ring) instead of the
  cage balls: another model, not a numerical device, whose limit is the steel balls' own. Its
  rungs are compared with a reference of their own model (``reference rigid cage dt=1e-8``),
  whose own row gives the difference between the two cage models (against the cage balls'
  reference);
- the fidelity presets of :mod:`signatelec.engines.fidelity`.

Each run covers the set-up phases, ``SETTLE_S`` for the spin-up transient, then
``N_PERIODS`` ball-pass periods; the comparison window is the part after the settling. Compared
(relative to the reference; :mod:`signatelec.studies.accuracy_metrics`): the mean resistance,
the amplitude of the resistance at the ball-pass frequency, the RMS difference of the resistance
traces (the setting's trace interpolated onto the reference's instants), and the largest ball
load.
Cost: wall time and CPU time per simulated second of bearing time, compile time excluded;
for the quasi-static tier, per second of the steady phase it returns. The CPU time is the one
compared (cost relative to the paper's setting, Pareto plot): the wall time of a shared machine
also counts the other processes.

Outputs (:func:`run_study`): ``accuracy_cost.parquet`` (one row per scene and setting),
``accuracy_cost.md`` (summary and per-scene tables), ``accuracy_cost.png`` (Pareto plot:
error against cost, log axes; both by :mod:`signatelec.studies.accuracy_report`), and with
``defects`` (``--defects``) the defect rows ``accuracy_cost_defects.{parquet,md}`` (the
quasi-static tier against the DEM on spalled scenes:
:mod:`signatelec.studies.accuracy_cost_defects`). Runs are
resumable: finished cases are kept in
``OUT/.cache/`` (``fresh=True`` / ``--fresh`` starts over).
"""

from __future__ import annotations

import io
import json
import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.config.scene import Scene
from signatelec.engines.fidelity import PRESETS, Preset, apply_fidelity, cage_mass_scale
from signatelec.io import write_bytes_atomic
from signatelec.studies.accuracy_cost_defects import write_rows as defect_rows
from signatelec.studies.accuracy_metrics import PAPER_SETTING, Trace, compare
from signatelec.studies.accuracy_report import markdown, plot

#: Time after the set-up left for the spin-up transient to damp before comparing, s.
SETTLE_S = 2e-3
#: Ball-pass periods compared after the settling (full study; --quick: QUICK_PERIODS).
N_PERIODS = 10
QUICK_PERIODS = 3
#: Time step of the reference runs, s.
REFERENCE_DT_S = 1e-8


@dataclass(frozen=True)
class StudyScene:
    """A study scene: F_r as a fraction of the bearing's C_r (seed 2.2.2), and the clearance."""

    name: str
    load_fraction: float
    clearance_m: float


SCENES: tuple[StudyScene, ...] = (
    StudyScene("light 0.1 Cr", 0.1, 0.0),
    StudyScene("heavy 0.4 Cr", 0.4, 0.0),
    StudyScene("preload -10 um", 0.2, -10e-6),
    StudyScene("zero clearance", 0.2, 0.0),
    StudyScene("clearance +40 um", 0.2, 40e-6),
)


@dataclass(frozen=True)
class Setting:
    """One rung of the ladder, applied to a study scene by
    :func:`signatelec.engines.fidelity.apply_fidelity`: a tier (``"quasistatic"``), a preset's
    name, or a :class:`~signatelec.engines.fidelity.Preset` of its own (see :func:`dem`)."""

    name: str
    fidelity: str | Preset

    def definition(self) -> str:
        """What the setting does (a named preset's current bundle): cached rows must match."""
        bundle = self.fidelity
        if isinstance(bundle, str):
            bundle = PRESETS.get(bundle, bundle)
        return f"{self.name}: {bundle!r}"

    def scene(self, base: Scene) -> Scene:
        return apply_fidelity(base, self.fidelity)


def dem(name: str, **numerics) -> Setting:
    """A DEM setting; ``numerics`` are :class:`~signatelec.engines.fidelity.Preset` fields:
    ``dt_s`` (absolute) or ``dt_limit_fraction`` (of the scene's stability limit),
    ``integrator``, ``cage_mass_scale``, ``effects``."""
    return Setting(name, Preset(name, **numerics))


def _law(name: str) -> tuple[tuple[str, str], ...]:
    return (("contact_law", name),)


#: The rigid cage model instead of the seed's cage balls, the paper's steel and polyamide physics
#: otherwise (no mass scaling): its 7 g ring leaves dt at the steel balls' own limit.
_RIGID = (("cage", "rigid"),)

REFERENCE = dem("reference dt=1e-8", dt_s=REFERENCE_DT_S)
#: The rigid cage's own reference: its rungs are compared with it (another model, not a numerical
#: approximation of the cage balls); its row is compared with :data:`REFERENCE`.
REFERENCE_RIGID = dem("reference rigid cage dt=1e-8", dt_s=REFERENCE_DT_S, effects=_RIGID)
REFERENCES = (REFERENCE, REFERENCE_RIGID)


def reference_for(setting: Setting, scene: Scene) -> Setting:
    """The reference a setting is compared with: that of its cage model."""
    if setting is REFERENCE_RIGID or scene.effects.cage != "rigid":
        return REFERENCE
    return REFERENCE_RIGID


SETTINGS: tuple[Setting, ...] = (
    Setting("quasistatic", "quasistatic"),
    dem("dem verlet dt=2e-8", dt_s=2e-8),
    dem("dem verlet dt=5e-8", dt_s=5e-8),
    dem(PAPER_SETTING, dt_s=1e-7),
    dem("dem verlet dt=0.95 limit", dt_limit_fraction=0.95),
    dem("dem euler dt=2e-8", dt_s=2e-8, integrator="euler"),
    dem("dem euler dt=5e-8", dt_s=5e-8, integrator="euler"),
    dem("dem euler dt=1e-7", dt_s=1e-7, integrator="euler"),
    dem("dem euler dt=1.5e-7", dt_s=1.5e-7, integrator="euler"),
    dem("dem euler dt=0.9 limit", dt_limit_fraction=0.9, integrator="euler"),
    dem("dem linear law dt=1e-7", dt_s=1e-7, effects=_law("linear")),
    dem("dem linear law dt=0.95 limit", dt_limit_fraction=0.95, effects=_law("linear")),
    dem("dem harris law dt=1e-7", dt_s=1e-7, effects=_law("harris")),
    dem("dem hertz no gravity dt=1e-7", dt_s=1e-7, effects=(("gravity", "none"),)),
    dem("dem cage mass x10 dt=0.9 limit", dt_limit_fraction=0.9, cage_mass_scale=10.0),
    dem(
        "dem cage mass x10 euler dt=0.9 limit",
        dt_limit_fraction=0.9,
        cage_mass_scale=10.0,
        integrator="euler",
    ),
    dem("dem cage mass x80 dt=5e-7", dt_s=5e-7, cage_mass_scale=80.0),
    dem("dem cage mass x80 dt=0.9 limit", dt_limit_fraction=0.9, cage_mass_scale=80.0),
    *(
        dem(
            f"dem cage mass x80 euler dt={fraction} limit",
            dt_limit_fraction=fraction,
            cage_mass_scale=80.0,
            integrator="euler",
        )
        for fraction in (0.5, 0.75, 0.9)
    ),
    dem("dem cage mass x80 euler dt=1e-6", dt_s=1e-6, cage_mass_scale=80.0, integrator="euler"),
    dem("dem rigid cage dt=1e-7", dt_s=1e-7, effects=_RIGID),
    *(
        dem(f"dem rigid cage dt={fraction} limit", dt_limit_fraction=fraction, effects=_RIGID)
        for fraction in (0.5, 0.75, 0.9)
    ),
    *(
        dem(
            f"dem rigid cage euler dt={fraction} limit",
            dt_limit_fraction=fraction,
            integrator="euler",
            effects=_RIGID,
        )
        for fraction in (0.5, 0.75, 0.9)
    ),
)

QUICK_SCENES = (SCENES[3],)
QUICK_SETTINGS = (SETTINGS[0], SETTINGS[2], SETTINGS[3])


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
    base = Scene()
    scene = base.with_overrides(
        radial_load_n=study_scene.load_fraction * base.bearing.dynamic_load_rating_n,
        clearance_m=study_scene.clearance_m,
        omega_rad_s=config.omega_rad_s,
        spin_up_time_s=base.procedure.spin_up_time_s,  # the paper's 5 ms for every scene
    )
    bpf = scene.bearing.ball_pass_frequency_hz(config.omega_rad_s)
    duration = scene.setup_time_s + SETTLE_S + config.n_periods / bpf
    return scene.with_overrides(duration_s=duration, dt_s=REFERENCE_DT_S)


_WARM: set = set()


def _warm_up(scene: Scene) -> None:
    """Load (or compile) the scene's kernel, or the quasi-static tier, before it is timed."""
    from signatelec.engines.dem.spec import KernelSpec
    from signatelec.engines.simulate import simulate
    from signatelec.physics.stability import stability_limit

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
    from signatelec.physics.stability import stability_limit

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

    def _reference_path(self, scene_name: str, reference: str) -> Path:
        name = "".join(c if c.isalnum() else "_" for c in f"{reference} {scene_name}")
        return self.dir / f"{name}.npz"

    def reference(self, scene_name: str, reference: str = REFERENCE.name) -> Trace | None:
        path = self._reference_path(scene_name, reference)
        if not path.exists():
            return None
        with np.load(path) as data:
            return Trace(
                data["time_s"],
                data["resistance_ohm"],
                data["max_ball_load_n"],
                float(data["ball_pass_frequency_hz"]),
            )

    def save_reference(self, scene_name: str, reference: str, trace: Trace) -> None:
        path = self._reference_path(scene_name, reference)
        buffer = io.BytesIO()
        np.savez(buffer, **asdict(trace))
        write_bytes_atomic(path, buffer.getvalue())

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
    first = base_scene(config.scenes[0], config)
    references = tuple(
        ref
        for ref in REFERENCES
        if any(reference_for(st, st.scene(first)) is ref for st in (REFERENCE, *config.settings))
    )
    cases = [(s, st) for s in config.scenes for st in (*references, *config.settings)]
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(cases), desc="accuracy-cost", unit="case")
    for study_scene, setting in cases:
        if bar is not None:
            bar.set_postfix_str(f"{study_scene.name}: {setting.name}"[:60])
        cached = cache.rows.get((study_scene.name, setting.name))
        done = cached is not None and cached.get("definition") == setting.definition()
        if setting in REFERENCES:
            done = done and cache.reference(study_scene.name, setting.name) is not None
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
                if setting in REFERENCES:
                    cache.save_reference(study_scene.name, setting.name, trace)
                row["reference"] = reference_for(setting, scene).name
                reference = cache.reference(study_scene.name, row["reference"])
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


def run_study(
    out_dir: str | Path,
    quick: bool = False,
    progress: bool = True,
    fresh: bool = False,
    config: StudyConfig | None = None,
    log: Callable[[str], None] | None = print,
    defects: bool = False,
) -> dict[str, Path]:
    """Run the study into ``out_dir``; returns the paths of the table, the Markdown and the plot
    (``defects``: and of the defect rows, :mod:`signatelec.studies.accuracy_cost_defects`).

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
    write_bytes_atomic(paths["table"], table.to_parquet(index=False))
    write_bytes_atomic(paths["markdown"], markdown(table, run_time).encode("utf-8"))
    plot(table, paths["plot"])
    if defects:
        paths |= defect_rows(out, quick=quick)
    if log is not None:
        log(f"study run time {run_time:.0f} s (this invocation {elapsed:.0f} s)")
        for path in paths.values():
            log(f"wrote {path}")
    return paths


def with_presets(settings: Sequence[Setting]) -> tuple[Setting, ...]:
    """The settings followed by one per fidelity preset."""
    return (*settings, *(Setting(f"preset {name}", name) for name in PRESETS))
