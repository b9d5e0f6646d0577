"""Quasi-static tier: the DEM's steady-state tables from Harris' equilibrium, in milliseconds.

:func:`simulate_quasistatic` returns a :class:`~signatelec.engines.dem.run.SimulationResult` with
the
tables and columns of the DEM (``balls`` and ``signals``, electrical columns included) at the
scene's sample rate, for the recorded instants of the steady phase only (``time_s`` after the
spin-up; the DEM's recording grid ``k * record_every * dt_s``).

At each instant:

- the balls sit at their kinematic positions: ball k at ``psi_k(t) = psi_0 + theta_c(t) +
  2 pi k / Z`` with the cage angle ``theta_c = (R_inn / (R_inn + R_out)) * phi(t)``, ``phi`` the
  inner-ring angle of the seed's schedule (spin-up ramp, then omega), so the cage turns at the
  kinematic speed ``omega R_inn / (R_inn + R_out)``; each ball spins at the rolling speed
  ``-omega_c r_p / R_b``;
- the inner-ring shift ``s`` solves the 2D equilibrium ``sum_k Q_i,k(s) u_k = F`` of
  :func:`signatelec.physics.quasistatic.solve_equilibrium_over_time` (Harris 2001, 7.2-7.3): each
  ball
  has its inner and outer contacts in series under the scene's contact law (Hertz, Harris or
  linear, with the DEM's coefficients), carries its centrifugal force (``effects.centrifugal =
  "inertial"``) and, with ``effects.gravity = "standard"``, the radial part of its weight; the
  ring carries F_r and its own weight; the clearance (or preload) is the scene's final one
  (seed eq. 14);
- the ball centre lies on its radius where its outer contact overlap is the solved one;
- the electrical columns come from those loads by
:func:`signatelec.physics.electrical.bearing_electrics`
  (seed section 3), exactly as the DEM's do.

The equilibrium is solved by a small numba routine (:func:`solve_ring_equilibrium`): the same
equations and Newton method as :mod:`signatelec.physics.quasistatic`, one instant after another,
each
started from the previous one, so the whole steady phase costs about a millisecond. Instants it
does not converge on go to :func:`signatelec.physics.quasistatic.solve_equilibrium_over_time`;
``tests/test_quasistatic_tier.py`` checks the two agree to 1e-9.

What the tier leaves out (everything dynamic):

- the transient: no clearance, load or spin-up phase, hence no rows before the steady phase;
  ``phase`` is always "steady";
- impacts and rattling: balls entering the load zone do so smoothly, unloaded balls do not
  bounce between the races, contact damping does nothing;
- slip: balls roll without slip, so the cage speed is exactly kinematic and the tangential
  forces are zero (``inner_tangential_n = outer_tangential_n = 0``, ``drive_torque_n_m = 0``);
  friction plays no part;
- cage dynamics: the balls stay evenly spaced (the cage balls are not simulated; with the cage
  off, the DEM's balls may bunch and touch, the tier's never do), the tangential component of a
  ball's weight is ignored;
- the phase of the trace: the DEM's balls slip a little during spin-up, so over long runs its
  ball-pass phase drifts from the kinematic one of the tier.

Measured against the DEM (``docs/accuracy_cost``, five scenes from 0.1 to 0.4 C_r, -10 to
+40 um, against a dt = 1e-8 s reference): mean resistance within 0.2 %, largest ball load within
1.3 %, but the ball-pass amplitude of the resistance (0.13-0.22 % of its mean) off by -14 % to
+8 %, part of the DEM's ripple being dynamics. On the seed's scene it is 120-150x faster than the
DEM and 0.06 % from its mean resistance.

With ``outputs.energy`` the tier fills ``elastic_j`` (raceway contacts) and ``kinetic_j`` (rigid
kinematic motion of balls and cage balls); ``work_in_j`` and ``dissipated_j`` are NaN (the
quasi-static state has no history).

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
import pandas as pd
from numba import njit

from signatelec.config.bearing import INNER, OUTER, STANDARD_GRAVITY_M_S2
from signatelec.config.scene import Scene
from signatelec.engines.laws import scene_law
from signatelec.engines.results import PHASES, SimulationResult, phase_times
from signatelec.physics.quasistatic import (
    ACCEPTED_RTOL,
    epsilon_from_shift,
    solve_equilibrium_over_time,
)

_EPS = float(np.finfo(float).eps)
#: Equilibrium residual relative to the load carried: forces to ~1e-10, far below what the tier
#: leaves out, and one Newton step from the extrapolated start of most instants.
TIER_RTOL = 1e-10
_MAX_RING_ITERATIONS = 100
_MAX_BALL_ITERATIONS = 200
_MAX_HALVINGS = 60


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
    z = scene.bearing.n_balls
    psi = kinematic_cage_angle_rad(scene, time_s)[:, None] + 2.0 * math.pi * np.arange(z) / z
    return math.pi - np.remainder(math.pi - psi, 2.0 * math.pi)


def _kinematic_unit_vectors(scene: Scene, time_s):
    """(sin psi, -cos psi) of :func:`kinematic_ball_angles_rad`, by rotating ball 0's."""
    z = scene.bearing.n_balls
    cage = kinematic_cage_angle_rad(scene, time_s)[:, None]
    offset = 2.0 * math.pi * np.arange(z) / z
    sin_c, cos_c, sin_o, cos_o = np.sin(cage), np.cos(cage), np.sin(offset), np.cos(offset)
    return sin_c * cos_o + cos_c * sin_o, sin_c * sin_o - cos_c * cos_o


def steady_record_times_s(scene: Scene) -> np.ndarray:
    """The DEM's recorded instants ``k * record_every * dt_s`` that fall in the steady phase."""
    every, dt = scene.record_every, scene.numerics.dt_s
    n_rec = scene.n_steps // every
    t = np.arange(1, n_rec + 1) * every * dt
    return t[t > phase_times(scene)[2]]


# --- equilibrium: numba version of signatelec.physics.quasistatic's solver ------------------------


@njit(cache=True, inline="always")
def _force(d, c, n):
    if d <= 0.0:
        return 0.0
    return c * d if n == 1.0 else c * d * math.sqrt(d)


@njit(cache=True, inline="always")
def _energy(d, c, n):
    if d <= 0.0:
        return 0.0
    return 0.5 * c * d * d if n == 1.0 else 0.4 * c * d * d * math.sqrt(d)


@njit(cache=True, inline="always")
def _overlap(f, c, n):
    if f <= 0.0:
        return 0.0
    return f / c if n == 1.0 else (f / c) ** (2.0 / 3.0)


@njit(cache=True)
def _ball(approach, body, reach, ci, co, n, split):
    """One ball between the races (quasistatic._ball_state).

    ``reach`` is the overlap the body force alone makes on the race it presses the ball against
    (outer for ``body > 0``, inner for ``body < 0``): the ball touches both races when the
    approach exceeds it. Returns Q_i, Q_o, dQ_i/d(delta) (the contacts in series; 0 on one race),
    the potential (elastic energy minus the work of the body force), the signed outer overlap
    and the split x / delta of the approach (its inner overlap share; the ``split`` of the
    ball's previous evaluation starts the series solve and is returned when one race only).
    """
    both = approach > reach
    if both:
        if n == 1.5:
            x = _hertz_split(approach, body, ci, co, split) * approach
        else:
            x = (co * approach - body) / (ci + co)
        split = x / approach
    elif body > 0.0:
        x = approach - reach
    elif body < 0.0:
        x = reach
    else:
        x = 0.5 * min(approach, 0.0)
    out = approach - x
    xp, op = max(x, 0.0), max(out, 0.0)
    k = 0.0
    if n == 1.5:
        sx, so = math.sqrt(xp), math.sqrt(op)
        qi, qo = ci * xp * sx, co * op * so
        if both:
            ki, ko = 1.5 * ci * sx, 1.5 * co * so
            k = ki * ko / (ki + ko)
        pot = 0.4 * (qi * xp + qo * op) - body * out
    else:
        qi, qo = ci * xp, co * op
        if both:
            k = ci * co / (ci + co)
        pot = 0.5 * (qi * xp + qo * op) - body * out
    return qi, qo, k, pot, out, split


@njit(cache=True)
def _hertz_split(approach, body, ci, co, split):
    """Inner share x / delta of the approach of a ball in Hertz contact with both races.

    Safeguarded Newton on g(x) = c_i x^1.5 + b - c_o (delta - x)^1.5, increasing on (0, delta),
    from ``split * delta``. A Newton step below 1e-7 x leaves an error ~ (x g'' / 2 g')
    (1e-7)^2 x < 1e-14 x, so it is taken and the iteration stops; a step leaving the bracket
    bisects it instead.
    """
    lo, hi = 0.0, approach
    x = split * approach
    for _ in range(_MAX_BALL_ITERATIONS):
        out = approach - x
        sx, so = math.sqrt(x), math.sqrt(out)
        g = ci * x * sx + body - co * out * so
        if g < 0.0:
            lo = x
        elif g > 0.0:
            hi = x
        else:
            break
        step = g / (1.5 * (ci * sx + co * so))
        x_new = x - step
        if not (lo <= x_new <= hi):
            x_new = 0.5 * (lo + hi)
        if abs(step) <= 1e-7 * x or hi - lo <= 4.0 * _EPS * approach:
            x = x_new
            break
        x = x_new
    return x / approach


@njit(cache=True)
def _ring(sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, split, out):
    """Residual, Jacobian, potential and squeezed-ball count of the ring at shift (sx, sy).

    Fills the ball forces qi, qo, the outer overlaps out and the splits (inner overlap /
    approach, read as the start of each ball's series solve).
    """
    rx, ry = -fx, -fy
    j00 = j01 = j11 = 0.0
    pot = -(sx * fx + sy * fy)
    squeezed = 0
    for k in range(ux.shape[0]):
        a = sx * ux[k] + sy * uy[k] - clearance
        qi[k], qo[k], kk, p, out[k], split[k] = _ball(a, body[k], reach[k], ci, co, n, split[k])
        rx += qi[k] * ux[k]
        ry += qi[k] * uy[k]
        j00 += kk * ux[k] * ux[k]
        j01 += kk * ux[k] * uy[k]
        j11 += kk * uy[k] * uy[k]
        pot += p
        if kk > 0.0:
            squeezed += 1
    return rx, ry, j00, j01, j11, pot, squeezed


@njit(cache=True)
def _cold_start(ux, uy, body, clearance, fx, fy, ci, co, n):
    """quasistatic._cold_start: squeeze the two balls nearest the load direction."""
    load = math.hypot(fx, fy)
    if load == 0.0:
        return 0.0, 0.0
    dx, dy = fx / load, fy / load
    z = ux.shape[0]
    proj = np.empty(z)
    for k in range(z):
        proj[k] = ux[k] * dx + uy[k] * dy
    second = np.sort(proj)[z - 2]
    ball_load = 5.0 * load / z
    approach = _overlap(ball_load, ci, n) + _overlap(ball_load + max(body.max(), 0.0), co, n)
    magnitude = (max(clearance, 0.0) + approach) / min(max(second, 0.1), 1.0)
    return magnitude * dx, magnitude * dy


@njit(cache=True)
def _solve_instant(
    sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, floor, qi, qo, split, out
):
    """Damped Newton of quasistatic._equilibrium for one instant from (sx, sy).

    A start that squeezes fewer than two balls is replaced by the cold start. Returns
    ``(sx, sy, ok)`` with qi, qo, split, out at the returned shift.
    """
    load = math.hypot(fx, fy)
    rx, ry, j00, j01, j11, pot, squeezed = _ring(
        sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, split, out
    )
    if squeezed < 2:
        sx, sy = _cold_start(ux, uy, body, clearance, fx, fy, ci, co, n)
        rx, ry, j00, j01, j11, pot, squeezed = _ring(
            sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, split, out
        )
    current = True  # qi, qo, split, out belong to (sx, sy)
    for _ in range(_MAX_RING_ITERATIONS):
        carried = load + qi.sum()
        roundoff = 16.0 * _EPS * (math.hypot(sx, sy) + abs(clearance)) * (j00 + j11)
        res = math.hypot(rx, ry)
        if res <= max(TIER_RTOL * carried, roundoff):
            return sx, sy, True
        reg = 1e-12 * (j00 + j11) + floor
        a00, a11 = j00 + reg, j11 + reg
        det = a00 * a11 - j01 * j01
        dx = -(a11 * rx - j01 * ry) / det
        dy = -(a00 * ry - j01 * rx) / det
        slope = rx * dx + ry * dy
        t = 1.0
        accepted = False
        for _h in range(_MAX_HALVINGS):
            tx, ty = sx + t * dx, sy + t * dy
            nrx, nry, n00, n01, n11, npot, _ = _ring(
                tx, ty, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, split, out
            )
            # Armijo on the convex potential or, where it is flat to round-off, on the residual
            if npot <= pot + 1e-4 * t * slope or math.hypot(nrx, nry) <= (1.0 - 1e-4 * t) * res:
                sx, sy, rx, ry, j00, j01, j11, pot = tx, ty, nrx, nry, n00, n01, n11, npot
                accepted = True
                break
            t *= 0.5
        current = accepted
        if not accepted or math.hypot(dx, dy) <= 4.0 * _EPS * math.hypot(sx, sy):
            break
    if not current:
        rx, ry, j00, j01, j11, pot, _ = _ring(
            sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, split, out
        )
    roundoff = 16.0 * _EPS * (math.hypot(sx, sy) + abs(clearance)) * (j00 + j11)
    ok = math.hypot(rx, ry) <= max(ACCEPTED_RTOL * (load + qi.sum()), roundoff)
    return sx, sy, ok


@njit(cache=True)
def _solve_series(
    ux_all, uy_all, body, reach, clearance, fx, fy, ci, co, n, floor, shift, qi, qo, out, ok
):
    """Every instant in turn, each started from the extrapolation of the three before.

    ``ux_all, uy_all`` (T, Z): the balls' outward radial unit vectors (sin psi, -cos psi);
    ``body``, ``reach`` (T, Z): body forces and the overlaps they cause alone (see _ball).
    """
    t_count, z = ux_all.shape
    # the split of the approach without body force (exact then), the first start of every ball
    split = np.full(z, 1.0 / (1.0 + (ci / co) ** (1.0 / n)))
    for t in range(t_count):
        ux, uy = ux_all[t], uy_all[t]
        if t >= 3:
            sx = 3.0 * (shift[t - 1, 0] - shift[t - 2, 0]) + shift[t - 3, 0]
            sy = 3.0 * (shift[t - 1, 1] - shift[t - 2, 1]) + shift[t - 3, 1]
        elif t == 2:
            sx = 2.0 * shift[t - 1, 0] - shift[t - 2, 0]
            sy = 2.0 * shift[t - 1, 1] - shift[t - 2, 1]
        elif t == 1:
            sx, sy = shift[0, 0], shift[0, 1]
        else:
            sx, sy = 0.0, 0.0
        sx, sy, good = _solve_instant(
            sx,
            sy,
            ux,
            uy,
            body[t],
            reach[t],
            clearance,
            fx,
            fy,
            ci,
            co,
            n,
            floor,
            qi[t],
            qo[t],
            split,
            out[t],
        )
        shift[t, 0], shift[t, 1] = sx, sy
        ok[t] = good


class RingEquilibrium:
    """Solution of :func:`solve_ring_equilibrium`, arrays with a leading T axis."""

    def __init__(self, shift_xy_m, inner_force_n, outer_force_n, outer_overlap_m, fallback, ux, uy):
        self.shift_xy_m = shift_xy_m  # (T, 2)
        self.radial_unit_x = ux  # (T, Z), sin psi
        self.radial_unit_y = uy  # (T, Z), -cos psi
        self.inner_force_n = inner_force_n  # (T, Z)
        self.outer_force_n = outer_force_n  # (T, Z)
        self.outer_overlap_m = outer_overlap_m  # (T, Z), signed (< 0: gap to the outer race)
        self.fallback_instants = fallback  # instants solved by signatelec.physics.quasistatic


def solve_ring_equilibrium(scene: Scene, ball_angle_rad, unit_xy=None) -> RingEquilibrium:
    """Quasi-static equilibrium of the scene's inner ring at ball angles (T, Z).

    The equations of :func:`signatelec.physics.quasistatic.solve_equilibrium_over_time` with the
    scene's
    contact law (the DEM's coefficients, :func:`signatelec.engines.laws.scene_law`), clearance,
    speed, centrifugal force and gravity, solved instant after instant by a compiled damped
    Newton; instants it does not bring to ``ACCEPTED_RTOL`` are solved by that function.
    ``unit_xy``: ``(sin psi, -cos psi)`` when the caller has them.
    """
    b, op, e = scene.bearing, scene.operating, scene.effects
    psi = np.ascontiguousarray(ball_angle_rad, dtype=float)
    ux, uy = unit_xy if unit_xy is not None else (np.sin(psi), -np.cos(psi))
    coef, n = scene_law(scene)
    ci, co = float(coef[INNER]), float(coef[OUTER])
    # quasistatic.ball_body_force_n, with cos psi = -u_y at hand
    body = np.zeros(psi.shape)
    if e.centrifugal == "inertial":
        body += b.ball_mass_kg * b.cage_speed_rad_s(op.omega_rad_s) ** 2 * b.pitch_radius_m
    if e.gravity == "standard":
        body -= b.ball_mass_kg * STANDARD_GRAVITY_M_S2 * uy
    # overlap under the body force alone, on the race it presses the ball against
    reach = (np.abs(body) / np.where(body > 0.0, co, ci)) ** (1.0 / n)
    weight = b.inner_ring_mass_kg * STANDARD_GRAVITY_M_S2 if e.gravity == "standard" else 0.0
    fx, fy = 0.0, -(op.radial_load_n + weight)
    z = b.n_balls
    ball_load = max(abs(fy) / z, float(np.abs(body).max(initial=0.0)), 1.0)
    series = ball_load ** (1.0 / n) * (ci ** (-1.0 / n) + co ** (-1.0 / n))
    floor = 1e-10 * z * ball_load / series
    shape = psi.shape
    shift = np.zeros((shape[0], 2))
    qi, qo, out = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    ok = np.zeros(shape[0], dtype=np.bool_)
    if shape[0]:
        _solve_series(
            ux,
            uy,
            body,
            reach,
            op.clearance_m,
            fx,
            fy,
            ci,
            co,
            float(n),
            floor,
            shift,
            qi,
            qo,
            out,
            ok,
        )
    bad = np.flatnonzero(~ok)
    if bad.size:
        state = solve_equilibrium_over_time(
            psi[bad],
            b,
            op.radial_load_n,
            op.clearance_m,
            op.omega_rad_s,
            law=e.contact_law,
            centrifugal=e.centrifugal == "inertial",
            gravity=e.gravity == "standard",
            linear_stiffness_n_m=co if n == 1.0 else None,
        )
        shift[bad], qi[bad], qo[bad] = state.shift_xy_m, state.inner_force_n, state.outer_force_n
        approach = (
            ux[bad] * state.shift_xy_m[:, :1] + uy[bad] * state.shift_xy_m[:, 1:] - op.clearance_m
        )
        inner_overlap = np.where(qi[bad] > 0.0, (qi[bad] / ci) ** (1.0 / n), 0.0)
        out[bad] = approach - inner_overlap
    return RingEquilibrium(shift, qi, qo, out, bad, ux, uy)


# --- the tier ------------------------------------------------------------------------------------


def simulate_quasistatic(scene: Scene | None = None, *, progress: bool = False) -> SimulationResult:
    """The steady phase of ``scene`` by the quasi-static tier (see the module docstring).

    Same tables and columns as :func:`signatelec.engines.simulate.simulate` (``progress`` is
    accepted
    for the same signature and ignored), rows of the steady phase only. ``timings`` holds
    ``run_s`` (equilibrium), ``electrical_s``, ``total_s``, ``n_instants`` and ``compile_s``
    (the first call of a process loads the compiled solver); ``n_steps = 0``: no time step.
    """
    del progress
    t_start = time.perf_counter()
    scene = scene or Scene()
    b, op = scene.bearing, scene.operating
    z = b.n_balls
    t = steady_record_times_s(scene)
    n_rec = t.size
    psi = kinematic_ball_angles_rad(scene, t)

    compile_s = 0.0
    if not _solve_series.signatures:
        t0 = time.perf_counter()
        solve_ring_equilibrium(scene, psi[:1])
        compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    eq = solve_ring_equilibrium(scene, psi, _kinematic_unit_vectors(scene, t))
    run_s = time.perf_counter() - t0

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
        "x_m": (radius * eq.radial_unit_x).ravel(),
        "y_m": (radius * eq.radial_unit_y).ravel(),
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
        "phase": pd.Categorical.from_codes(np.full(n_rec, PHASES.index("steady")), PHASES),
        "inner_x_m": ix,
        "inner_y_m": iy,
        "delta_r_m": delta_r,
        "epsilon": epsilon_from_shift(delta_r, op.clearance_m),
        "outer_race_radius_m": np.full(n_rec, r_out),
        "applied_load_n": np.full(n_rec, op.radial_load_n),
        "inner_omega_rad_s": np.full(n_rec, omega),
        "drive_torque_n_m": np.zeros(n_rec),
        "cage_speed_rad_s": np.full(n_rec, omega_c),
        "loaded_balls": (eq.inner_force_n > 0.0).sum(axis=1).astype(np.int32),
        "max_ball_load_n": eq.inner_force_n.max(axis=1, initial=0.0),
    }
    if scene.outputs.energy:
        signals.update(_energy_columns(scene, eq, radius, omega_c, spin))
    timings = {
        "tier": "quasistatic",
        "kernel": "quasistatic",
        "compile_s": compile_s,
        "run_s": run_s,
        "n_steps": 0,
        "us_per_step": 0.0,
        "n_instants": int(n_rec),
        "us_per_instant": 1e6 * run_s / max(n_rec, 1),
        "fallback_instants": int(eq.fallback_instants.size),
    }
    if scene.outputs.electrical:
        from signatelec.physics.electrical import bearing_electrics

        t0 = time.perf_counter()
        # theta of eq. 16 is pi: each ball lies on its radius and the ring shift (microns, beside a
        # 30 mm pitch radius) turns its inner contact by ~1e-4 rad, cos theta = -1 + 1e-8.
        el = bearing_electrics(eq.inner_force_n, eq.outer_force_n, b, op.injected_current_a)
        signals["resistance_ohm"] = el.resistance_ohm
        signals["max_current_density_a_m2"] = el.max_current_density_a_m2
        for name in ("current_a", "potential_v", "inner_area_m2", "outer_area_m2"):
            balls[name] = getattr(el, name).ravel()
        timings["electrical_s"] = time.perf_counter() - t0
        timings["electrical_us_per_instant"] = 1e6 * timings["electrical_s"] / max(n_rec, 1)
    result = SimulationResult(scene, pd.DataFrame(balls), pd.DataFrame(signals), timings, None)
    timings["total_s"] = time.perf_counter() - t_start - compile_s
    return result


def _energy_columns(scene: Scene, eq: RingEquilibrium, radius, omega_c, spin) -> dict:
    """The DEM's energy columns for the quasi-static state (no history: work and loss NaN)."""
    b = scene.bearing
    coef, n = scene_law(scene)
    ci, co = float(coef[INNER]), float(coef[OUTER])
    d_i = np.where(eq.inner_force_n > 0.0, (eq.inner_force_n / ci) ** (1.0 / n), 0.0)
    d_o = np.maximum(eq.outer_overlap_m, 0.0)
    factor = 0.4 if n == 1.5 else 0.5  # 2/5 c d^2.5 (Hertz), 1/2 k d^2 (linear)
    elastic = factor * (ci * d_i ** (n + 1.0) + co * d_o ** (n + 1.0))
    kinetic = 0.5 * b.ball_mass_kg * (omega_c * radius) ** 2 + 0.5 * b.ball_inertia_kg_m2 * spin**2
    cage = 0.5 * b.cage_ball_mass_kg * (omega_c * b.pitch_radius_m) ** 2 * b.n_balls
    nan = np.full(radius.shape[0], np.nan)
    return {
        "work_in_j": nan,
        "dissipated_j": nan.copy(),
        "elastic_j": elastic.sum(axis=1),
        "kinetic_j": kinetic.sum(axis=1) + (cage if scene.effects.cage == "balls" else 0.0),
    }
