"""Run a scene through the DEM kernel and return pandas tables.

Procedure of the seed (2.2.1-2.2.2, 4): the balls start on the pitch circle, touching both rings
(zero-clearance geometry of table 1); phase 1 moves the outer race radius to R_out + clearance
(eq. 14); phase 2 applies F_r on the inner ring along -y; phase 3 spins the inner ring up along a
sinusoid to omega; then steady running until ``duration_s``.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from signatelec.config.bearing import STANDARD_GRAVITY_M_S2, contact_properties
from signatelec.config.scene import Scene, SceneError
from signatelec.engines.dem.build import get_kernel
from signatelec.engines.dem.records import (
    OK,
    REC_ROTATION,
    State,
    new_parameters,
    new_recording,
    new_state,
)
from signatelec.engines.dem.spec import KernelSpec
from signatelec.engines.results import (
    LOADED_FORCE_N,
    MIN_SHIFT_M,
    PHASES,
    DivergenceError,
    SimulationResult,
    phase_times,
    record_rate_hz,
    to_frame,
)
from signatelec.engines.stream import STREAM_BLOCK_INSTANTS, TableStream, arrow_table
from signatelec.physics.contact import (
    critical_damping,
    hertz_critical_damping,
    mindlin_coefficient,
    tangential_stiffness_from_overlap,
)
from signatelec.physics.defect_geometry import contact_radii_m, defect_table
from signatelec.physics.laws import scene_law
from signatelec.physics.stability import stability_limit

_CONTACT_NAMES = {
    0: "inner-raceway overlap",
    1: "outer-raceway overlap",
    2: "ball/cage overlap",
    3: "cage-boundary overlap",
    4: "ball/ball overlap",
    5: "ball/pocket overlap",
    -1: "position or velocity (not finite)",
}


def kernel_parameters(scene: Scene) -> np.void:
    """The parameter record of ``scene`` (:data:`signatelec.engines.dem.records.PARAMS`)."""
    b, op = scene.bearing, scene.operating
    coef, exponent = scene_law(scene)
    props = contact_properties(b)
    p = new_parameters()
    p["dt_s"] = scene.numerics.dt_s
    p["ball_radius_m"] = b.ball_radius_m
    p["cage_ball_radius_m"] = b.cage_ball_radius_m
    p["inner_race_radius_m"] = b.inner_race_radius_m
    p["outer_race_radius_m"] = b.outer_race_radius_m
    p["clearance_m"] = op.clearance_m
    p["pitch_radius_m"] = b.pitch_radius_m
    p["ball_mass_kg"] = b.ball_mass_kg
    p["ball_inertia_kg_m2"] = b.ball_inertia_kg_m2
    cage = scene.effects.cage
    p["cage_ball_mass_kg"] = b.cage_ball_mass_kg if cage == "balls" else 0.0
    if cage == "rigid":
        p["rigid_cage_mass_kg"] = b.rigid_cage_mass_kg
        p["rigid_cage_inertia_kg_m2"] = b.rigid_cage_inertia_kg_m2
        p["pocket_gap_m"] = b.pocket_radius_m - b.ball_radius_m
    p["pocket_step_cos"] = math.cos(2.0 * math.pi / b.n_balls)
    p["pocket_step_sin"] = math.sin(2.0 * math.pi / b.n_balls)
    p["inner_ring_mass_kg"] = b.inner_ring_mass_kg
    p["radial_load_n"] = op.radial_load_n
    p["omega_rad_s"] = op.omega_rad_s
    p["clearance_end_s"], p["load_end_s"], p["spin_up_end_s"] = phase_times(scene)
    p["gravity_m_s2"] = STANDARD_GRAVITY_M_S2
    p["friction_coefficient"] = b.friction_coefficient
    p["max_overlap_fraction"] = 0.1
    p["normal_coefficient"] = coef
    for kind, c in enumerate(props):
        # damping factors: C = factor (linear) or factor * delta^{1/4} (Hertz), eq. 5 and 9
        if exponent == 1.0:
            p["normal_damping_factor"][kind] = critical_damping(coef[kind], c.reduced_mass_kg)
        else:
            p["normal_damping_factor"][kind] = hertz_critical_damping(
                1.0, coef[kind], c.reduced_mass_kg
            )
    for side in (0, 1):
        c = props[side]
        if exponent == 1.0:
            kt = 2.0 / 3.0 * coef[side]  # eq. 5: K_t / K_n in [2/3, 1]
        else:
            mc = mindlin_coefficient(c.radius_eq_m, c.shear_modulus_pa, c.poisson)
            kt = tangential_stiffness_from_overlap(1.0, coef[side], mc)
        p["tangential_stiffness_factor"][side] = kt
        # critical tangential damping 2 sqrt(K_t m*), K_t = factor sqrt(delta): factor delta^{1/4}
        p["tangential_damping_factor"][side] = critical_damping(kt, c.reduced_mass_kg)
    _abnormal_parameters(scene, p)
    return p


def _abnormal_parameters(scene: Scene, p: np.void) -> None:
    """The defects, the lobes and the abnormal loads of ``scene`` into record ``p``."""
    p["defect_count"] = len(scene.defects)
    p["defect_table"] = defect_table(scene, p["defect_table"].shape[1])
    p["contact_radius_m"] = contact_radii_m(scene.bearing)
    if scene.housing.out_of_round:
        p["lobes"] = scene.housing.out_of_round_lobes
        p["lobe_amplitude_m"] = scene.housing.out_of_round_amplitude_m
    omega = scene.operating.omega_rad_s
    if omega > 0.0:  # the kernel scales it with the schedule's speed squared
        p["unbalance_n_s2"] = scene.loads.unbalance_amplitude_n(omega) / omega**2
    p["unbalance_phase_rad"] = scene.loads.unbalance_phase_rad
    times, loads = scene.loads.load_table_time_s, scene.loads.load_table_radial_load_n
    p["load_table_count"] = len(times)
    p["load_table_time_s"][: len(times)] = times
    p["load_table_load_n"][: len(loads)] = loads


def initial_state(scene: Scene) -> State:
    """Balls and cage balls on the pitch circle, ball 0 at ``initial_ball_angle_rad`` from the
    load direction, everything at rest; the rigid cage centred, each pocket on its ball."""
    b = scene.bearing
    z = b.n_balls
    psi = scene.operating.initial_ball_angle_rad + 2.0 * math.pi * np.arange(z) / z
    psi_c = psi + math.pi / z
    pos = np.zeros((2 * z + 1, 2))
    rp = b.pitch_radius_m
    pos[:z, 0], pos[:z, 1] = rp * np.sin(psi), -rp * np.cos(psi)
    if scene.effects.cage == "rigid":
        pos[z + 1, 0] = psi[0]  # the cage angle; its centre (row z) at the origin
    else:
        pos[z : 2 * z, 0], pos[z : 2 * z, 1] = rp * np.sin(psi_c), -rp * np.cos(psi_c)
    return new_state(pos)


def _raw_tables(scene: Scene, n_rec: int, rec) -> tuple[dict, dict]:
    """The ``balls`` and ``signals`` columns of the ``n_rec`` instants of ``rec`` (numpy arrays;
    ``phase`` as codes into PHASES): a streamed run writes them without pandas."""
    z = scene.bearing.n_balls
    t, pos, vel, spin, fcon, sched, energy = (a[:n_rec] for a in rec)  # Recording order
    ring = 2 * z
    bx, by = pos[:, :z, 0], pos[:, :z, 1]
    r2 = bx * bx + by * by
    orbit = (bx * vel[:, :z, 1] - by * vel[:, :z, 0]) / r2
    balls = {
        "time_s": np.repeat(t, z),
        "ball": np.tile(np.arange(z, dtype=np.int32), n_rec),
        "angle_rad": np.arctan2(bx, -by).ravel(),
        "x_m": bx.ravel(),
        "y_m": by.ravel(),
        "orbit_speed_rad_s": orbit.ravel(),
        "spin_rad_s": spin.ravel(),
        "inner_force_n": fcon[:, :, 0].ravel(),
        "outer_force_n": fcon[:, :, 1].ravel(),
        "inner_tangential_n": fcon[:, :, 2].ravel(),
        "outer_tangential_n": fcon[:, :, 3].ravel(),
    }
    ix, iy = pos[:, ring, 0], pos[:, ring, 1]
    delta_r = np.hypot(ix, iy)
    clearance = scene.operating.clearance_m
    with np.errstate(divide="ignore", invalid="ignore"):
        # eq. 15 is undefined for a centred ring: below 1 nm of shift epsilon is NaN, not +-1e19
        eps = np.where(delta_r > MIN_SHIFT_M, 0.5 * (1.0 - clearance / delta_r), np.nan)
    t1, t2, t3 = phase_times(scene)
    phase = np.select([t <= t1, t <= t2, t <= t3], [0, 1, 2], 3).astype(np.int8)
    signals = {
        "time_s": t,
        "phase": phase,
        "inner_x_m": ix,
        "inner_y_m": iy,
        "delta_r_m": delta_r,
        "epsilon": eps,
        "outer_race_radius_m": sched[:, 0],
        "applied_load_n": sched[:, 1],
        "inner_omega_rad_s": sched[:, 2],
        "drive_torque_n_m": sched[:, 3],
        "cage_speed_rad_s": orbit.mean(axis=1),
        "loaded_balls": (fcon[:, :, 0] > LOADED_FORCE_N).sum(axis=1).astype(np.int32),
        "max_ball_load_n": fcon[:, :, 0].max(axis=1),
    }
    if scene.effects.cage == "rigid":
        signals["cage_x_m"] = pos[:, z, 0]
        signals["cage_y_m"] = pos[:, z, 1]
        signals["cage_angle_rad"] = pos[:, z + 1, 0]
        signals["cage_body_speed_rad_s"] = vel[:, z + 1, 0]
        balls["pocket_force_n"] = fcon[:, :, 4].ravel()
    if any(d.location == "ball" for d in scene.defects):
        balls["ball_rotation_rad"] = fcon[:, :, REC_ROTATION].ravel()  # tracked with ball defects
    if scene.outputs.energy:
        signals["work_in_j"] = energy[:, 0]
        signals["dissipated_j"] = energy[:, 1]
        signals["elastic_j"] = energy[:, 2]
        signals["kinetic_j"] = energy[:, 3]
    return balls, signals


def _phase_at(scene: Scene, time_s: float) -> str:
    t1, t2, t3 = phase_times(scene)
    return PHASES[int(np.searchsorted([t1, t2, t3], time_s))]


def _divergence_message(scene: Scene, status: np.ndarray, cure: str | None = None) -> str:
    """The step, time, phase, body and contact of a divergence, and its cure when measured."""
    z = scene.bearing.n_balls
    step, body, what = int(status[1]), int(status[2]), int(status[3])
    if body < z:
        name = f"ball {body}"
    elif body < 2 * z:
        name = f"cage ball {body - z}"
    else:
        name = "inner ring"
    limit = "" if what == -1 else " beyond 10 % of the body radius"
    time_s = (step + 1) * scene.numerics.dt_s
    head = (
        f"simulation diverged at step {step} (t = {time_s:.6g} s): {name}, "
        f"{_CONTACT_NAMES[what]}{limit}, in the {_phase_at(scene, time_s)} phase; "
    )
    return head + (cure or "reduce numerics.dt_s or check the scene")


#: Steady running a cure probe must pass after the point where the run diverged, s.
PROBE_MARGIN_S = 2e-3


def _probe(scene: Scene, fail_s: float, **changes) -> bool:
    """Whether ``scene`` with ``changes`` runs past the point where it diverged (with the set-up
    moved by the changes) plus PROBE_MARGIN_S, without the electrical post-processing."""
    try:
        # a longer set-up may not fit the scene's duration: room first, then the probe's end
        room = max(scene.numerics.duration_s, fail_s) + 1.0
        trial = scene.with_overrides(**changes, duration_s=room)
        shift = trial.setup_time_s - scene.setup_time_s
        end = min(max(fail_s + shift, trial.setup_time_s) + PROBE_MARGIN_S, max(fail_s, 0.0) + 1.0)
        trial = trial.with_overrides(duration_s=end)
        trial = replace(trial, outputs=replace(trial.outputs, electrical=False))
        simulate_dem(trial, cure=False)
    except (DivergenceError, SceneError):
        return False
    return True


def measured_cure(scene: Scene, status: np.ndarray) -> str:
    """Rerun short probes of a diverged scene, a spin-up 2x then 4x longer, a halved dt, then
    the other cage models, and say which runs past the point of divergence (the first that does)."""
    fail_s = (int(status[1]) + 1) * scene.numerics.dt_s
    t_spin = scene.procedure.spin_up_time_s
    trials = []
    if scene.procedure.spin_up and _phase_at(scene, fail_s) in ("spin_up", "steady"):
        trials.append(("a longer spin-up", {"spin_up_time_s": 2.0 * t_spin}))
        trials.append(("a longer spin-up", {"spin_up_time_s": 4.0 * t_spin}))
    trials.append(("a smaller time step", {"dt_s": 0.5 * scene.numerics.dt_s}))
    tried = []
    for label, changes in trials:
        key, value = next(iter(changes.items()))
        setting = f"{'procedure' if key == 'spin_up_time_s' else 'numerics'}.{key} = {value:.3g}"
        if _probe(scene, fail_s, **changes):
            tried.append(f"cure measured: {label}, {setting}, runs past that point")
            break
        tried.append(f"{setting} ({label}) still diverges")
    else:
        others = [c for c in ("rigid", "none") if c != scene.effects.cage]
        for cage in others:
            other = replace(scene, effects=replace(scene.effects, cage=cage))
            if _probe(other, fail_s):
                tried.append(f'cure measured: another cage model, effects.cage = "{cage}", runs')
                break
            tried.append(f'effects.cage = "{cage}" still diverges')
        else:
            tried.append("check the scene")
    return "; ".join(tried)


class _BlockElectrics:
    """Seed section 3 block by block: resistance, ball currents and potentials at every recorded
    instant, with the current-density figures of the whole run gathered over the blocks."""

    def __init__(self, scene: Scene):
        self.scene = scene
        self.setup_peak = self.steady_peak = 0.0
        self.n_over = self.n_checked = 0
        self.seconds = 0.0

    def add(self, balls, signals, fcon: np.ndarray, pos: np.ndarray) -> None:
        from signatelec.physics.electrical import DENSITY_LIMIT_A_M2, bearing_electrics

        t0 = time.perf_counter()
        scene = self.scene
        z = scene.bearing.n_balls
        steady = signals["phase"] == PHASES.index("steady")
        el = bearing_electrics(
            fcon[:, :, 0],
            fcon[:, :, 1],
            scene.bearing,
            scene.operating.injected_current_a,
            ball_xy_m=pos[:, :z],
            inner_ring_xy_m=pos[:, 2 * z],
            ball_ball_force_n=fcon[:, :, 4] if scene.effects.cage == "none" else None,
            density_limit_a_m2=np.inf,  # warned once for the run (finish)
        )
        density = el.max_current_density_a_m2
        self.setup_peak = max(self.setup_peak, float(density[~steady].max(initial=0.0)))
        self.steady_peak = max(self.steady_peak, float(density[steady].max(initial=0.0)))
        self.n_over += int(((density > DENSITY_LIMIT_A_M2) & steady).sum())
        self.n_checked += int(steady.sum())
        signals["resistance_ohm"] = el.resistance_ohm
        signals["max_current_density_a_m2"] = el.max_current_density_a_m2
        for name in ("current_a", "potential_v", "inner_area_m2", "outer_area_m2"):
            balls[name] = getattr(el, name).ravel()
        self.seconds += time.perf_counter() - t0

    def finish(self, timings: dict, n_instants: int) -> None:
        """The run's timings, and one warning when the steady phase exceeds the seed's limit."""
        from signatelec.physics.electrical import DENSITY_LIMIT_A_M2, warn_current_density

        if self.n_over:
            current = self.scene.operating.injected_current_a
            warn_current_density(
                self.n_over, self.n_checked, self.steady_peak, DENSITY_LIMIT_A_M2, current
            )
        # the set-up's first contacts are tiny and carry the whole current: information only
        timings["setup_peak_current_density_a_m2"] = self.setup_peak
        timings["steady_peak_current_density_a_m2"] = self.steady_peak
        timings["electrical_s"] = self.seconds
        timings["electrical_us_per_instant"] = 1e6 * self.seconds / max(n_instants, 1)


def process_age_s() -> float | None:
    """Seconds since this process started (Linux /proc, 10 ms resolution), else None."""
    import os

    try:
        with open("/proc/self/stat", "rb") as fh:
            start_ticks = int(fh.read().rsplit(b")", 1)[1].split()[19])
        with open("/proc/uptime", "rb") as fh:
            uptime_s = float(fh.read().split()[0])
        return max(uptime_s - start_ticks / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError):
        return None


def _block_tables(scene: Scene, n_rec: int, rec, electrics: _BlockElectrics | None):
    """The tables of the ``n_rec`` instants held in ``rec``, electrical columns included."""
    balls, signals = _raw_tables(scene, n_rec, rec)
    if electrics is not None:
        electrics.add(balls, signals, rec.fcon[:n_rec], rec.pos[:n_rec])
    return balls, signals


def checked_limit(scene: Scene):
    """The stability limit of ``scene``; :class:`SceneError` when its dt is above it."""
    limit = stability_limit(scene)
    if scene.numerics.dt_s > limit.dt_limit_s:
        raise SceneError(
            f"numerics.dt_s = {scene.numerics.dt_s:g}: above the {limit.describe()}; "
            f"use dt_s <= {limit.dt_limit_s:.3g} s"
        )
    return limit


def simulate_dem(
    scene: Scene | None = None,
    *,
    progress: bool = False,
    cure: bool = True,
    stream: TableStream | None = None,
) -> SimulationResult:
    """Simulate ``scene`` (default: the seed's scene) with the DEM kernel.

    Raises :class:`SceneError` when dt is above the stability limit (before running) and
    :class:`DivergenceError` when the run leaves the physical range; with ``cure``, its message
    names the setting that cures it, measured by short probe runs (:func:`measured_cure`).
    With ``stream`` the kernel records into a buffer of
    :data:`~signatelec.engines.stream.STREAM_BLOCK_INSTANTS` instants whose tables go to the
    stream each time it fills (the result then holds no tables); otherwise the whole run is one
    block, returned in memory. The values are the same either way.
    """
    scene = scene or Scene()
    limit = checked_limit(scene)
    spec = KernelSpec.from_scene(scene)
    p = kernel_parameters(scene)
    st = initial_state(scene)
    n_steps, every = scene.n_steps, scene.record_every
    n_total = n_steps // every
    block = n_total if stream is None else max(1, min(n_total, STREAM_BLOCK_INSTANTS))
    rec = new_recording(block, scene.bearing.n_balls)

    t0 = time.perf_counter()
    # compiled, or loaded from the on-disk cache (without numba when it can), before anything runs
    kern = get_kernel(spec, calls={"start": (p, st), "run": (p, st, rec, 0, 0, every, 0)})
    kern.start(p, st)
    compile_s = time.perf_counter() - t0

    electrics = _BlockElectrics(scene) if scene.outputs.electrical else None
    first_step_s = process_age_s()  # start-up: interpreter, imports, kernel load, scene
    chunk = max(every, (n_steps // 200) // every * every)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n_steps, unit="step", unit_scale=True, desc="simulate", leave=False)
    run_s = run_cpu_s = 0.0
    step = rec_index = flushed = 0
    while step < n_steps:
        if stream is not None and rec_index == block:
            stream.write(*map(arrow_table, _block_tables(scene, rec_index, rec, electrics)))
            rec_index, flushed = 0, flushed + 1
        free = block - rec_index
        # run until the buffer is full (its last instant is recorded at step k every - 1)
        to_fill = (step // every + free) * every - step if free else n_steps - step
        count = min(chunk, n_steps - step, to_fill)
        t0, cpu0 = time.perf_counter(), time.process_time()
        rec_index = kern.run(p, st, rec, step, count, every, rec_index)
        run_s += time.perf_counter() - t0
        run_cpu_s += time.process_time() - cpu0
        step += count
        if bar is not None:
            bar.update(count)
        if st.status[0] != OK:
            break
    if bar is not None:
        bar.close()
    if st.status[0] != OK:
        remedy = measured_cure(scene, st.status) if cure else None
        raise DivergenceError(_divergence_message(scene, st.status, remedy))

    balls = signals = None
    if stream is None:
        balls, signals = map(to_frame, _block_tables(scene, rec_index, rec, electrics))
    elif rec_index or not flushed:
        stream.write(*map(arrow_table, _block_tables(scene, rec_index, rec, electrics)))
    timings = dem_timings(scene, limit, spec.key, compile_s, run_s, run_cpu_s)
    timings["process_to_first_step_s"] = first_step_s
    if electrics is not None:
        electrics.finish(timings, n_total)
    return SimulationResult(scene, balls, signals, timings, limit)


def dem_timings(scene: Scene, limit, kernel: str, compile_s, run_s, run_cpu_s) -> dict:
    """The timings and chosen settings a DEM run of ``scene`` reports."""
    n_steps = scene.n_steps
    return {
        "compile_s": compile_s,
        "run_s": run_s,
        "n_steps": n_steps,
        "us_per_step": 1e6 * run_s / max(n_steps, 1),
        "run_cpu_s": run_cpu_s,
        "cpu_us_per_step": 1e6 * run_cpu_s / max(n_steps, 1),
        "kernel": kernel,
        "dt_s": scene.numerics.dt_s,
        "record_rate_hz": record_rate_hz(scene),
        "spin_up_time_s": scene.procedure.spin_up_time_s,
        "duration_s": scene.numerics.duration_s,
        "stability_limit_s": limit.dt_limit_s,
        "chosen": sorted(scene.auto),
    }


def dem_result(scene, rec, rec_index, limit, kernel, compile_s, run_s, run_cpu_s):
    """The in-memory result of a DEM run of ``scene`` that recorded ``rec_index`` instants of
    ``rec`` (a :class:`~.records.Recording`, the whole run): its tables, timings and, with the
    electrical output, the electrical columns (one block of :class:`_BlockElectrics`)."""
    electrics = _BlockElectrics(scene) if scene.outputs.electrical else None
    balls, signals = map(to_frame, _block_tables(scene, rec_index, rec, electrics))
    timings = dem_timings(scene, limit, kernel, compile_s, run_s, run_cpu_s)
    if electrics is not None:
        electrics.finish(timings, rec_index)
    return SimulationResult(scene, balls, signals, timings, limit)
