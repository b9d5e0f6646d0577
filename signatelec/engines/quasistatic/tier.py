"""Quasi-static tier: the DEM's steady-state tables from Harris' equilibrium, in milliseconds.

:func:`simulate_quasistatic` returns a :class:`~signatelec.engines.results.SimulationResult`
with the tables and columns of the DEM (``balls`` and ``signals``, electrical columns included)
at the scene's sample rate, for the recorded instants of the steady phase only (``time_s`` after
the spin-up; the DEM's recording grid ``k * record_every * dt_s``).

At each instant:

- the balls sit at their kinematic positions: ball k at ``psi_k(t) = psi_0 + theta_c(t) +
  2 pi k / Z`` with the cage angle ``theta_c = (R_inn / (R_inn + R_out)) * phi(t)``, ``phi`` the
  inner-ring angle of the seed's schedule (spin-up ramp, then omega), so the cage turns at the
  kinematic speed ``omega R_inn / (R_inn + R_out)``; each ball spins at the rolling speed
  ``-omega_c r_p / R_b``;
- the inner-ring shift ``s`` solves the 2D equilibrium ``sum_k Q_i,k(s) u_k = F`` of
  :func:`signatelec.physics.quasistatic.solve_equilibrium_over_time` (Harris 2001, 7.2-7.3):
  each ball has its inner and outer contacts in series under the scene's contact law (Hertz,
  Harris or linear, with the DEM's coefficients), carries its centrifugal force
  (``effects.centrifugal = "inertial"``) and, with ``effects.gravity = "standard"``, the
  radial part of its weight; the
  ring carries F_r and its own weight; the clearance (or preload) is the scene's final one
  (seed eq. 14). The solver is that of the theory (:mod:`signatelec.physics.ring_equilibrium`,
  compiled, each instant started from the ones before), run to ``TIER_RTOL``: the whole steady
  phase costs about a millisecond;
- the ball centre lies on its radius where its outer contact overlap is the solved one;
- defects and abnormal loads (:mod:`signatelec.config.defects`): each ball's clearance at each
  instant grows by the drop of the defects under its two contacts and by the out-of-round outer
  race's radius at its angle (the functions of :mod:`signatelec.physics.defects` the DEM kernel
  inlines, with the kinematic inner-ring angle and ball rotation), and the load at each instant
  is the tabulated F_r plus the unbalance turning with the ring;
- the electrical columns come from those loads by
  :func:`signatelec.physics.electrical.bearing_electrics` (seed section 3), exactly as the
  DEM's do.

What the tier leaves out (everything dynamic):

- the transient: no clearance, load or spin-up phase, hence no rows before the steady phase;
  ``phase`` is always "steady";
- impacts and rattling: balls entering the load zone do so smoothly, unloaded balls do not
  bounce between the races, contact damping does nothing;
- slip: balls roll without slip, so the cage speed is exactly kinematic and the tangential
  forces are zero (``inner_tangential_n = outer_tangential_n = 0``, ``drive_torque_n_m = 0``);
  friction plays no part;
- cage dynamics: the balls stay evenly spaced (the cage balls or the rigid cage are not
  simulated, only their kinematic motion for the kinetic energy; with the cage
  off, the DEM's balls may bunch and touch, the tier's never do); with the cage balls, the
  chain that carries the tangential part of the balls' weights pushes them outward
  (:func:`signatelec.physics.quasistatic.cage_chain_force_n`: it matters at zero radial load,
  where those weights are the load); with the rigid cage, the push of its pockets, which carry
  the tangential part of the weights and the cage's own weight
  (:func:`signatelec.physics.quasistatic.rigid_cage_force_n`; friction at the races left out);
- the phase of the trace: the DEM's balls slip a little during spin-up, so over long runs its
  ball-pass phase drifts from the kinematic one of the tier.

Its accuracy and cost against the DEM (mean resistance, ball-pass amplitude, largest ball load,
CPU time) are measured by the accuracy-cost study: ``docs/accuracy_cost/accuracy_cost.md``, row
``quasistatic``.

With ``outputs.energy`` the tier fills ``elastic_j`` (raceway contacts) and ``kinetic_j`` (rigid
kinematic motion of balls and cage balls or rigid cage); ``work_in_j`` and ``dissipated_j`` are
NaN (the quasi-static state has no history).

References
----------
Seed: C. Machado, M. Guessasma, E. Bellenger, *Modelling of ball bearing loading by DEM for
electromechanical coupling*, sections 2.2 and 3, eqs 14-18.
T. A. Harris, *Rolling Bearing Analysis*, 4th ed., Wiley, 2001, sections 7.2-7.3, chapter 10.
"""

from __future__ import annotations

import math
import time

import numpy as np

from signatelec.config.bearing import INNER, OUTER
from signatelec.config.scene import Scene
from signatelec.engines.quasistatic.period import PeriodMap, ball_angles_rad, use_period_map
from signatelec.engines.results import (
    PHASES,
    SimulationResult,
    phase_times,
    record_rate_hz,
    to_frame,
)
from signatelec.physics.contact import NORMAL_LAWS
from signatelec.physics.defects import clearance_offsets_m, tabulated_loads_n
from signatelec.physics.laws import scene_law
from signatelec.physics.load_distribution import epsilon_from_shift
from signatelec.physics.quasistatic import ring_equilibrium, ring_load_xy_n
from signatelec.physics.ring_equilibrium import RingSolution, solver_loaded

#: Equilibrium residual relative to the load carried: forces to ~1e-10, far below what the tier
#: leaves out, and one Newton step from the extrapolated start of most instants.
TIER_RTOL = 1e-10


# --- the kinematics of the tier -------------------------------------------------------------------


def inner_ring_angle_rad(scene: Scene, time_s) -> np.ndarray:
    """Inner-ring angle phi(t) = integral of the seed's speed schedule, rad.

    Zero until the end of the load phase t2, then the sinusoidal spin-up
    ``omega (1 - cos(pi (t - t2) / (t3 - t2))) / 2`` (a step when the spin-up is off), then omega.
    """
    t = np.asarray(time_s, dtype=float)
    _, t2, t3 = phase_times(scene)
    omega = scene.operating.omega_rad_s
    ramp = t3 - t2
    if t.size and t.min() >= t3:  # the tier's instants: the spin-up is over (one pass, not six)
        done = 0.5 * omega * (ramp - ramp / math.pi * math.sin(math.pi)) if ramp > 0.0 else 0.0
        return done + omega * (t - t3)
    during = np.clip(t - t2, 0.0, ramp)
    if ramp > 0.0:
        spin_up = 0.5 * omega * (during - ramp / math.pi * np.sin(math.pi * during / ramp))
    else:
        spin_up = np.zeros_like(t)
    return spin_up + omega * np.maximum(t - t3, 0.0)


def kinematic_cage_angle_rad(scene: Scene, time_s) -> np.ndarray:
    """Angle of ball 0 rolling without slip: psi_0 + (R_inn / (R_inn + R_out)) phi(t), rad."""
    ratio = scene.bearing.cage_speed_rad_s(1.0)
    return scene.operating.initial_ball_angle_rad + ratio * inner_ring_angle_rad(scene, time_s)


def kinematic_ball_angles_rad(scene: Scene, time_s) -> np.ndarray:
    """Angles (T, Z) of the balls rolling without slip, from -y counter-clockwise, in (-pi, pi]."""
    return ball_angles_rad(kinematic_cage_angle_rad(scene, time_s), scene.bearing.n_balls)


def steady_record_times_s(scene: Scene) -> np.ndarray:
    """The DEM's recorded instants ``k * record_every * dt_s`` that fall in the steady phase."""
    every, dt = scene.record_every, scene.numerics.dt_s
    n_rec = scene.n_steps // every
    end = phase_times(scene)[2]
    # from a few instants before the set-up's end, the same products k * every * dt as all
    first = max(1, int(end / (every * dt)) - 2)
    t = np.arange(first, n_rec + 1) * every * dt
    return t[np.searchsorted(t, end, side="right") :]


# --- equilibrium ---------------------------------------------------------------------------------


def radial_load_over_time_n(scene: Scene, time_s) -> np.ndarray:
    """F_r at times (T,) after the set-up: the scene's load table (the rule of the DEM's
    schedule, physics.defects.tabulated_load_n), else its constant radial_load_n, N."""
    loads, static = scene.loads, scene.operating.radial_load_n
    times = np.asarray(loads.load_table_time_s, dtype=float)
    table = np.asarray(loads.load_table_radial_load_n, dtype=float)
    end = phase_times(scene)[2]
    t = np.asarray(time_s, dtype=float)
    if not times.size:
        return np.full(t.shape, float(static))
    return tabulated_loads_n(np.ascontiguousarray(t - end), times, table, float(static))


def abnormal_conditions(scene: Scene, ball_angle_rad, time_s):
    """Each ball's clearance (T, Z) and the load on the ring (T, 2) at ball angles (T, Z) and
    times (T,) of a scene with defects or abnormal loads."""
    t = np.asarray(time_s, dtype=float)
    b, op, loads = scene.bearing, scene.operating, scene.loads
    phi = inner_ring_angle_rad(scene, t)
    # the balls roll without slip: spin -omega_c r_p / R_b (Bearing.ball_spin_rad_s)
    rotation = b.ball_spin_rad_s(1.0) * phi
    psi = np.asarray(ball_angle_rad, dtype=float)
    rotation = np.broadcast_to(rotation[:, None], psi.shape)
    clearance = op.clearance_m + clearance_offsets_m(scene, psi, phi, rotation)
    static = ring_load_xy_n(b, 0.0, scene.effects.gravity == "standard")  # the ring's weight
    unbalance = loads.unbalance_amplitude_n(op.omega_rad_s)
    angle = phi + loads.unbalance_phase_rad
    load = np.empty((t.size, 2))
    load[:, 0] = static[0] + unbalance * np.sin(angle)
    load[:, 1] = static[1] - radial_load_over_time_n(scene, t) - unbalance * np.cos(angle)
    return clearance, load


def solve_ring_equilibrium(
    scene: Scene, ball_angle_rad, unit_xy=None, time_s=None, start_xy_m=None
) -> RingSolution:
    """Quasi-static equilibrium of the scene's inner ring at ball angles (T, Z).

    The equations of :func:`signatelec.physics.quasistatic.solve_equilibrium_over_time` with the
    scene's contact law (the DEM's coefficients, :func:`signatelec.physics.laws.scene_law`),
    clearance, speed, centrifugal force and gravity, solved by the same compiled Newton
    (:mod:`signatelec.physics.ring_equilibrium`) to ``TIER_RTOL``. ``unit_xy``: the balls'
    ``(sin psi, -cos psi)`` when the caller has them; ``time_s`` (T,) the instants, which a scene
    with defects or abnormal loads needs (:func:`abnormal_conditions`); ``start_xy_m`` (T, 2)
    each instant's starting shift (instants far apart), else each starts from the ones before.
    """
    op, e = scene.operating, scene.effects
    coef, n = scene_law(scene)
    clearance, load = op.clearance_m, None
    if scene.abnormal and time_s is not None:
        clearance, load = abnormal_conditions(scene, ball_angle_rad, time_s)
    return ring_equilibrium(
        ball_angle_rad,
        scene.bearing,
        op.radial_load_n,
        clearance,
        op.omega_rad_s,
        ((float(coef[INNER]), float(coef[OUTER])), float(n)),
        centrifugal=e.centrifugal == "inertial",
        gravity=e.gravity == "standard",
        rtol=TIER_RTOL,
        unit_xy=unit_xy,
        load_xy_n=load,
        cage=e.cage,
        initial_shift_xy_m=start_xy_m,
    )


# --- the tier ------------------------------------------------------------------------------------


def instant_columns(scene: Scene, t, psi, start_xy_m=None) -> tuple[dict, dict, dict]:
    """The tables' columns (``balls`` raveled, ``signals``) of the quasi-static state at each
    instant of ``t`` with ball angles ``psi`` (T, Z), solved instant by instant (``start_xy_m``
    (T, 2): each instant's starting shift), and the time its
    parts took (``run_s`` the equilibrium, ``electrical_s``). The electrical network warns of no
    current density: the caller warns once for the run (:func:`density_warning`)."""
    b, op = scene.bearing, scene.operating
    z = b.n_balls
    n_rec = t.size
    t0 = time.perf_counter()
    ux, uy = np.sin(psi), -np.cos(psi)
    eq = solve_ring_equilibrium(scene, psi, (ux, uy), t, start_xy_m)
    spent = {"run_s": time.perf_counter() - t0}

    omega = op.omega_rad_s
    omega_c = b.cage_speed_rad_s(omega)
    spin = b.ball_spin_rad_s(omega)
    r_out = b.outer_race_radius_m + op.clearance_m
    radius = r_out - b.ball_radius_m + eq.outer_overlap_m
    n_rows = n_rec * z
    balls = {
        "time_s": np.repeat(t, z),
        "ball": np.tile(np.arange(z, dtype=np.int32), n_rec),
        "angle_rad": psi.ravel(),
        "x_m": (radius * ux).ravel(),
        "y_m": (radius * uy).ravel(),
        "orbit_speed_rad_s": np.full(n_rows, omega_c),
        "spin_rad_s": np.full(n_rows, spin),
        "inner_force_n": eq.inner_force_n.ravel(),
        "outer_force_n": eq.outer_force_n.ravel(),
        "inner_tangential_n": np.zeros(n_rows),
        "outer_tangential_n": np.zeros(n_rows),
    }
    ix, iy = eq.shift_xy_m[:, 0], eq.shift_xy_m[:, 1]
    delta_r = np.hypot(ix, iy)
    signals = {
        "time_s": t,
        "phase": _steady_phase(n_rec),
        "inner_x_m": ix,
        "inner_y_m": iy,
        "delta_r_m": delta_r,
        "epsilon": epsilon_from_shift(delta_r, op.clearance_m),
        "outer_race_radius_m": np.full(n_rec, r_out),
        "applied_load_n": radial_load_over_time_n(scene, t),
        "inner_omega_rad_s": np.full(n_rec, omega),
        "drive_torque_n_m": np.zeros(n_rec),
        "cage_speed_rad_s": np.full(n_rec, omega_c),
        "loaded_balls": (eq.inner_force_n > 0.0).sum(axis=1).astype(np.int32),
        "max_ball_load_n": eq.inner_force_n.max(axis=1, initial=0.0),
    }
    if scene.outputs.energy:
        signals.update(_energy_columns(scene, eq, radius, omega_c, spin))
    if scene.outputs.electrical:
        from signatelec.physics.electrical import bearing_electrics

        t0 = time.perf_counter()
        # theta of eq. 16 is pi: each ball lies on its radius and the ring shift (microns, beside a
        # 30 mm pitch radius) turns its inner contact by ~1e-4 rad, cos theta = -1 + 1e-8.
        el = bearing_electrics(
            eq.inner_force_n, eq.outer_force_n, b, op.injected_current_a, density_limit_a_m2=np.inf
        )
        signals["resistance_ohm"] = el.resistance_ohm
        signals["max_current_density_a_m2"] = el.max_current_density_a_m2
        for name in ("current_a", "potential_v", "inner_area_m2", "outer_area_m2"):
            balls[name] = getattr(el, name).ravel()
        spent["electrical_s"] = time.perf_counter() - t0
    return balls, signals, spent


def _steady_phase(n: int):
    import pandas as pd

    return pd.Categorical.from_codes(np.full(n, PHASES.index("steady")), PHASES)


def density_warning(scene: Scene, densities: list[np.ndarray]) -> None:
    """One current-density warning for the run's instants (seed section 3), as the DEM's."""
    from signatelec.physics.electrical import DENSITY_LIMIT_A_M2, warn_current_density

    density = np.concatenate(densities) if densities else np.zeros(0)
    over = int((density > DENSITY_LIMIT_A_M2).sum())
    if over:
        current = scene.operating.injected_current_a
        largest = float(density.max())
        warn_current_density(over, density.size, largest, DENSITY_LIMIT_A_M2, current, False)


def simulate_quasistatic(
    scene: Scene | None = None, *, progress: bool = False, stream=None
) -> SimulationResult:
    """The steady phase of ``scene`` by the quasi-static tier (see the module docstring).

    Same tables and columns as :func:`signatelec.engines.simulate.simulate` (``progress`` is
    accepted for the same signature and ignored), rows of the steady phase only. ``timings`` holds
    ``run_s`` (equilibrium), ``electrical_s``, ``total_s``, ``n_instants`` and ``compile_s``
    (the first call of a process loads the compiled solver); ``n_steps = 0``: no time step.

    A long steady phase of a ball-pass periodic scene
    (:func:`signatelec.engines.quasistatic.period.ball_pass_periodic`) is solved over one
    ball-pass period once and every instant mapped onto it
    (:class:`~signatelec.engines.quasistatic.period.PeriodMap`; ``timings["period_map"]``);
    otherwise instant by instant. With ``stream``
    (:class:`~signatelec.engines.stream.TableStream`) the tables go to it in blocks of
    :data:`~signatelec.engines.stream.STREAM_BLOCK_INSTANTS` instants.
    """
    from signatelec.engines.stream import STREAM_BLOCK_INSTANTS

    del progress
    t_start = time.perf_counter()
    scene = scene or Scene()
    t = steady_record_times_s(scene)
    n_rec = t.size

    compile_s = 0.0
    if not solver_loaded():
        t0 = time.perf_counter()
        solve_ring_equilibrium(scene, kinematic_ball_angles_rad(scene, t[:1]))
        compile_s = time.perf_counter() - t0
    spent = {"run_s": 0.0}
    if scene.outputs.electrical:
        spent["electrical_s"] = 0.0
    mapper = None
    if use_period_map(scene, n_rec):
        t0 = time.perf_counter()
        mapper = PeriodMap(scene, instant_columns, kinematic_cage_angle_rad)
        compile_s += mapper.compile_s
        spent["period_grid_s"] = time.perf_counter() - t0 - mapper.compile_s
    size = n_rec if stream is None else STREAM_BLOCK_INSTANTS
    densities = []
    balls = signals = None
    for first in range(0, max(n_rec, 1), max(size, 1)):
        tb = t[first : first + size]
        if mapper is not None:
            b, s, block_spent = mapper.columns(tb)
        else:
            b, s, block_spent = instant_columns(scene, tb, kinematic_ball_angles_rad(scene, tb))
        for key, value in block_spent.items():
            spent[key] = spent.get(key, 0.0) + value
        if "max_current_density_a_m2" in s:
            densities.append(s["max_current_density_a_m2"])
        if stream is not None:
            stream.write(b, s)
        else:
            balls, signals = to_frame(b, copy=False), to_frame(s, copy=False)
    density_warning(scene, densities)
    run_s = spent.pop("run_s")
    timings = {
        "tier": "quasistatic",
        "kernel": "quasistatic",
        "compile_s": compile_s,
        "run_s": run_s,
        "n_steps": 0,
        "us_per_step": 0.0,
        "n_instants": int(n_rec),
        "us_per_instant": 1e6 * run_s / max(n_rec, 1),
        "record_rate_hz": record_rate_hz(scene),
    }
    if "electrical_s" in spent:
        timings["electrical_s"] = spent.pop("electrical_s")
        timings["electrical_us_per_instant"] = 1e6 * timings["electrical_s"] / max(n_rec, 1)
    if mapper is not None:
        timings["period_map"] = mapper.describe()
        timings.update(spent)  # period_grid_s (the period solved once), map_s (the instants)
    result = SimulationResult(scene, balls, signals, timings, None)
    timings["total_s"] = time.perf_counter() - t_start - compile_s
    return result


def _energy_columns(scene: Scene, eq: RingSolution, radius, omega_c, spin) -> dict:
    """The DEM's energy columns for the quasi-static state (no history: work and loss NaN)."""
    b = scene.bearing
    coef, n = scene_law(scene)
    energy = NORMAL_LAWS[float(n)].energy
    elastic = energy(eq.inner_overlap_m, coef[INNER]) + energy(eq.outer_overlap_m, coef[OUTER])
    kinetic = 0.5 * b.ball_mass_kg * (omega_c * radius) ** 2 + 0.5 * b.ball_inertia_kg_m2 * spin**2
    if scene.effects.cage == "balls":
        cage = 0.5 * b.cage_ball_mass_kg * (omega_c * b.pitch_radius_m) ** 2 * b.n_balls
    elif scene.effects.cage == "rigid":
        cage = 0.5 * b.rigid_cage_inertia_kg_m2 * omega_c**2
    else:
        cage = 0.0
    nan = np.full(radius.shape[0], np.nan)
    return {
        "work_in_j": nan,
        "dissipated_j": nan.copy(),
        "elastic_j": elastic.sum(axis=1),
        "kinetic_j": kinetic.sum(axis=1) + cage,
    }
