"""Quasi-static equilibrium of the inner ring: the one compiled solver of the package.

:func:`solve_ring` solves, at each of T instants, the 2D equilibrium of the inner ring

    sum_k Q_i,k(s) u_k = F

for its shift s (Harris 2001, sections 7.2-7.3, in 2D and for arbitrary ball angles). Each ball
is a free body between the races: its inner and outer contacts are in series, d_i + d_o =
s . u_k - Delta_r, and it carries its outward body force b_k, Q_o = Q_i + b_k. The contact laws
are those of :mod:`signatelec.physics.contact` (:data:`~signatelec.physics.contact.NORMAL_LAWS`),
compiled by numba from that same source, as the DEM kernel does. Both the theory
(:func:`signatelec.physics.quasistatic.solve_equilibrium_over_time`) and the quasi-static tier
(:mod:`signatelec.engines.quasistatic.tier`) call it, with their own tolerance.

Method: the residual ``R(s) = sum_k Q_i,k u_k - F`` is the gradient of a convex potential (the
balls' elastic energy minus the work of the body forces and of F), so Newton on the analytic
Jacobian ``sum_k (dQ_i,k / d delta_k) u_k u_k^T``, damped by backtracking on that potential, is
globally convergent. The Jacobian is regularised while singular (fewer than two balls squeezed),
and a start squeezing fewer than two balls is replaced by one along the load that squeezes the
two balls nearest the load direction. Instants are solved in turn, each started from the
extrapolation of the three before (instant 0 from ``start_xy_m``), so a time series costs about
one Newton step an instant. Per ball, the series split of the approach is a safeguarded Newton
that stops once its step falls below 1e-7 of the deflection (error then ~1e-14 of it).

Shapes: ``ux, uy, body_n`` (T, Z), ``[instant, ball]``: the balls' outward radial unit vectors
u = (sin psi, -cos psi) and body forces; the solution holds (T, 2) shifts and (T, Z) forces and
overlaps.

References
----------
T. A. Harris, *Rolling Bearing Analysis*, 4th ed., Wiley, 2001, sections 7.2-7.3.
Seed: C. Machado, M. Guessasma, E. Bellenger, *Modelling of ball bearing loading by DEM for
electromechanical coupling*, eq. 14 (clearance) and eqs 3, 6-10 (contact laws).
"""

from __future__ import annotations

import hashlib
import inspect
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from signatelec.physics.contact import NORMAL_LAWS

_EPS = float(np.finfo(float).eps)
_MAX_RING_ITERATIONS = 100
_MAX_BALL_ITERATIONS = 200
_MAX_HALVINGS = 60
#: Residual, relative to the load carried, accepted when Newton stalls on round-off before the
#: tolerance asked (1e-12 for the theory, 1e-10 for the tier).
ACCEPTED_RTOL = 1e-9
#: A ball's series split stops after a Newton step below this fraction of its deflection.
_SPLIT_STEP_RTOL = 1e-7


def contact_laws_fingerprint() -> str:
    """SHA-256 (16 hex digits) of the source of the contact laws this module compiles."""
    text = "".join(inspect.getsource(f) for law in NORMAL_LAWS.values() for f in law)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


#: Fingerprint of the contact laws the solver's cached machine code holds. numba's cache keys a
#: function on its own file only, while this module compiles the laws of contact.py into its
#: functions: a law changed there must change this file too, or the cache would serve the old
#: law. When the fingerprint no longer matches, the solver compiles without cache (right
#: physics, seconds per process) and tests/test_quasistatic.py fails until this line is updated.
COMPILED_CONTACT_LAWS = "ec5c9b4d9fd605cc"
_CACHE = contact_laws_fingerprint() == COMPILED_CONTACT_LAWS

_jit = njit(cache=_CACHE, inline="always", error_model="numpy")
_hertz_force, _hertz_stiffness, _hertz_energy, _hertz_overlap = map(_jit, NORMAL_LAWS[1.5])
_linear_force, _linear_stiffness, _linear_energy, _linear_overlap = map(_jit, NORMAL_LAWS[1.0])


# --- the normal law of an exponent (contact.NORMAL_LAWS, compiled) -------------------------------
# Four dispatchers of one shape, written out: a factory would make closures, which numba's cache
# does not serve (they recompile in every process).


@_jit
def law_force(overlap_m, coefficient, exponent):
    if exponent == 1.0:
        return _linear_force(overlap_m, coefficient)
    return _hertz_force(overlap_m, coefficient)


@_jit
def law_stiffness(overlap_m, coefficient, exponent):
    if exponent == 1.0:
        return _linear_stiffness(overlap_m, coefficient)
    return _hertz_stiffness(overlap_m, coefficient)


@_jit
def law_energy(overlap_m, coefficient, exponent):
    if exponent == 1.0:
        return _linear_energy(overlap_m, coefficient)
    return _hertz_energy(overlap_m, coefficient)


@_jit
def law_overlap(force_n, coefficient, exponent):
    if exponent == 1.0:
        return _linear_overlap(force_n, coefficient)
    return _hertz_overlap(force_n, coefficient)


# --- one ball between the races (Harris 7.2) -----------------------------------------------------


@_jit
def _unit_force_split(ci, co, n):
    """x / delta of a ball carrying one force on both races: exact without body force."""
    inner, outer = law_overlap(1.0, ci, n), law_overlap(1.0, co, n)
    return inner / (inner + outer)


@njit(cache=_CACHE, error_model="numpy")
def _series_split(approach, body, ci, co, n, split):
    """Inner deflection x in (0, delta) with c_i x^n + b = c_o (delta - x)^n, as x / delta.

    Safeguarded Newton from ``split * delta`` on the residual, increasing in x and changing sign
    on [0, delta]: every evaluation narrows a bracket, a step leaving it bisects it. A step below
    ``_SPLIT_STEP_RTOL`` x leaves an error ~ (x g'' / 2 g') (1e-7)^2 x < 1e-14 x: it is taken and
    the iteration stops (the linear law converges in one step).
    """
    lo, hi = 0.0, approach
    x = split * approach
    for _ in range(_MAX_BALL_ITERATIONS):
        out = approach - x
        g = law_force(x, ci, n) + body - law_force(out, co, n)
        if g < 0.0:
            lo = x
        elif g > 0.0:
            hi = x
        else:
            break
        step = g / (law_stiffness(x, ci, n) + law_stiffness(out, co, n))
        x_new = x - step
        if not (lo <= x_new <= hi):
            x_new = 0.5 * (lo + hi)
        converged = abs(step) <= _SPLIT_STEP_RTOL * x or hi - lo <= 4.0 * _EPS * approach
        x = x_new
        if converged:
            break
    return x / approach


@njit(cache=_CACHE, error_model="numpy")
def _ball(approach, body, reach, ci, co, n, split):
    """One ball between the races at ``approach`` = s . u - Delta_r, with body force ``body``.

    ``reach`` is the overlap the body force alone makes on the race it presses the ball against
    (outer for ``body > 0``, inner for ``body < 0``): the ball touches both races when the
    approach exceeds it. Returns Q_i, Q_o, dQ_i/d(delta) (the contacts in series; 0 on one race),
    the potential (elastic energy minus the work of the body force), the inner and the outer
    overlap (signed: < 0 a gap) and the split x / delta of the approach (``split``, the ball's
    previous one, starts the series solve and is returned unchanged on one race).
    """
    both = approach > reach
    if both:
        split = _series_split(approach, body, ci, co, n, split)
        x = split * approach
    elif body > 0.0:  # resting on the outer race under its body force
        x = approach - reach
    elif body < 0.0:  # hanging on the inner race
        x = reach
    else:  # touching neither: halfway across the gap
        x = 0.5 * min(approach, 0.0)
    out = approach - x
    qi, qo = law_force(x, ci, n), law_force(out, co, n)
    k = 0.0
    if both:
        ki, ko = law_stiffness(x, ci, n), law_stiffness(out, co, n)
        k = ki * ko / (ki + ko)
    potential = law_energy(x, ci, n) + law_energy(out, co, n) - body * out
    return qi, qo, k, potential, x, out, split


@njit(cache=_CACHE, error_model="numpy")
def _reach(body, ci, co, n, reach):
    """Overlap under the body force alone, on the race it presses each ball against."""
    for k in range(body.shape[0]):
        reach[k] = law_overlap(abs(body[k]), co if body[k] > 0.0 else ci, n)


@njit(cache=_CACHE, error_model="numpy")
def ball_forces(approach, body, ci, co, n, inner_force, outer_force):
    """Q_i and Q_o of balls (flat arrays) at given approaches, started from the exact split."""
    reach = np.empty(body.shape[0])
    _reach(body, ci, co, n, reach)
    split = _unit_force_split(ci, co, n)
    for k in range(approach.shape[0]):
        qi, qo, _, _, _, _, _ = _ball(approach[k], body[k], reach[k], ci, co, n, split)
        inner_force[k], outer_force[k] = qi, qo


# --- the ring ------------------------------------------------------------------------------------


@njit(cache=_CACHE, error_model="numpy")
def _ring(sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, xi, xo, split):
    """Residual, Jacobian, potential and squeezed-ball count of the ring at shift (sx, sy).

    Fills the ball forces qi, qo, the inner and outer overlaps xi, xo and the splits.
    """
    rx, ry = -fx, -fy
    j00 = j01 = j11 = 0.0
    potential = -(sx * fx + sy * fy)
    squeezed = 0
    for k in range(ux.shape[0]):
        a = sx * ux[k] + sy * uy[k] - clearance[k]
        qi[k], qo[k], kk, p, xi[k], xo[k], split[k] = _ball(
            a, body[k], reach[k], ci, co, n, split[k]
        )
        rx += qi[k] * ux[k]
        ry += qi[k] * uy[k]
        j00 += kk * ux[k] * ux[k]
        j01 += kk * ux[k] * uy[k]
        j11 += kk * uy[k] * uy[k]
        potential += p
        if kk > 0.0:
            squeezed += 1
    return rx, ry, j00, j01, j11, potential, squeezed


@njit(cache=_CACHE, error_model="numpy")
def _cold_start(ux, uy, body, clearance, fx, fy, ci, co, n):
    """A shift along the load that squeezes at least the two balls nearest the load direction.

    Each of them gets the approach of a ball carrying 5 F / Z (Stribeck's design value) on top
    of any clearance, so the first Jacobian is not singular even with a large clearance.
    """
    load = math.hypot(fx, fy)
    if load == 0.0:
        return 0.0, 0.0
    dx, dy = fx / load, fy / load
    first = second = -math.inf
    for k in range(ux.shape[0]):
        p = ux[k] * dx + uy[k] * dy
        if p > first:
            first, second = p, first
        elif p > second:
            second = p
    ball_load = 5.0 * load / ux.shape[0]
    approach = law_overlap(ball_load, ci, n) + law_overlap(ball_load + max(body.max(), 0.0), co, n)
    magnitude = (max(clearance.max(), 0.0) + approach) / min(max(second, 0.1), 1.0)
    return magnitude * dx, magnitude * dy


@njit(cache=_CACHE, error_model="numpy")
def _solve_instant(
    sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, floor, rtol, qi, qo, xi, xo, split
):
    """Damped Newton for one instant from (sx, sy); returns ``(sx, sy, converged)``.

    Converged: a residual within ``rtol`` of the load carried, F + sum Q_i (or within the
    round-off of the approaches s . u - Delta_r, which lose digits when the deflections are tiny
    beside the clearance). The iteration also ends on a Newton step at round-off level or one
    no halving makes acceptable; the instant then counts as converged within ``ACCEPTED_RTOL``.
    qi, qo, xi, xo, split are those of the returned shift.
    """
    load = math.hypot(fx, fy)
    gap = max(abs(clearance.max()), abs(clearance.min()))
    rx, ry, j00, j01, j11, pot, squeezed = _ring(
        sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, xi, xo, split
    )
    if squeezed < 2:
        sx, sy = _cold_start(ux, uy, body, clearance, fx, fy, ci, co, n)
        rx, ry, j00, j01, j11, pot, squeezed = _ring(
            sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, xi, xo, split
        )
    current = True  # qi, qo, xi, xo, split belong to (sx, sy)
    for _ in range(_MAX_RING_ITERATIONS):
        roundoff = 16.0 * _EPS * (math.hypot(sx, sy) + gap) * (j00 + j11)
        res = math.hypot(rx, ry)
        if res <= max(rtol * (load + qi.sum()), roundoff):
            return sx, sy, True
        reg = 1e-12 * (j00 + j11) + floor
        a00, a11 = j00 + reg, j11 + reg
        det = a00 * a11 - j01 * j01
        dx = -(a11 * rx - j01 * ry) / det
        dy = -(a00 * ry - j01 * rx) / det
        slope = rx * dx + ry * dy  # < 0: the regularised Jacobian is positive definite
        t = 1.0
        accepted = False
        for _h in range(_MAX_HALVINGS):
            tx, ty = sx + t * dx, sy + t * dy
            nrx, nry, n00, n01, n11, npot, _ = _ring(
                tx, ty, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, xi, xo, split
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
            sx, sy, ux, uy, body, reach, clearance, fx, fy, ci, co, n, qi, qo, xi, xo, split
        )
    roundoff = 16.0 * _EPS * (math.hypot(sx, sy) + gap) * (j00 + j11)
    ok = math.hypot(rx, ry) <= max(max(ACCEPTED_RTOL, rtol) * (load + qi.sum()), roundoff)
    return sx, sy, ok


@njit(cache=_CACHE, error_model="numpy")
def _solve_series(ux, uy, body, clearance, fx, fy, ci, co, n, floor, rtol, start, out):
    """Every instant in turn, each started from the extrapolation of the three before, or,
    when ``start`` (S, 2) has a row per instant, from its own row (instants far apart).

    ``clearance`` (T, Z): each ball's clearance at each instant; ``fx, fy`` (T,): the load."""
    shift, qi, qo, xi, xo, ok = out
    t_count, z = ux.shape
    split = np.full(z, _unit_force_split(ci, co, n))
    reach = np.empty(z)
    own = start.shape[0] == t_count and t_count > 1
    for t in range(t_count):
        if own:
            sx, sy = start[t, 0], start[t, 1]
        elif t >= 3:
            sx = 3.0 * (shift[t - 1, 0] - shift[t - 2, 0]) + shift[t - 3, 0]
            sy = 3.0 * (shift[t - 1, 1] - shift[t - 2, 1]) + shift[t - 3, 1]
        elif t == 2:
            sx = 2.0 * shift[1, 0] - shift[0, 0]
            sy = 2.0 * shift[1, 1] - shift[0, 1]
        elif t == 1:
            sx, sy = shift[0, 0], shift[0, 1]
        else:
            sx, sy = start[0, 0], start[0, 1]
        _reach(body[t], ci, co, n, reach)
        sx, sy, good = _solve_instant(
            sx,
            sy,
            ux[t],
            uy[t],
            body[t],
            reach,
            clearance[t],
            fx[t],
            fy[t],
            ci,
            co,
            n,
            floor,
            rtol,
            qi[t],
            qo[t],
            xi[t],
            xo[t],
            split,
        )
        shift[t, 0], shift[t, 1], ok[t] = sx, sy, good


# --- the Python entry point ----------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RingSolution:
    """Equilibrium of the inner ring at T instants (arrays with a leading T axis)."""

    shift_xy_m: np.ndarray  # (T, 2) inner-ring centre displacement s
    inner_force_n: np.ndarray  # (T, Z) ball/inner-raceway force Q_i
    outer_force_n: np.ndarray  # (T, Z) ball/outer-raceway force Q_o
    inner_overlap_m: np.ndarray  # (T, Z) signed: < 0 a gap to the inner race
    outer_overlap_m: np.ndarray  # (T, Z) signed: < 0 a gap to the outer race
    converged: np.ndarray  # (T,) bool: residual within rtol, or ACCEPTED_RTOL after a stall


def solver_loaded() -> bool:
    """Whether this process has the compiled solver at hand (compiled or loaded from the cache)."""
    return bool(_solve_series.signatures)


def series_overlap_m(force_n, coefficients, exponent: float) -> float:
    """Approach d_i + d_o of a ball carrying ``force_n`` on both races (Harris 7.2), m.

    ``coefficients``: (c_inner, c_outer) of the normal law F = c d^n.
    """
    ci, co = coefficients
    return float(
        law_overlap(float(force_n), ci, exponent) + law_overlap(float(force_n), co, exponent)
    )


def solve_ring(
    ux,
    uy,
    body_n,
    clearance_m: float,
    load_xy_n,
    coefficients,
    exponent: float,
    rtol: float,
    start_xy_m=(0.0, 0.0),
) -> RingSolution:
    """Equilibrium of the inner ring at T instants (see the module docstring).

    Parameters
    ----------
    ux, uy : array_like, shape (T, Z)
        Outward radial unit vectors of the balls, (sin psi, -cos psi).
    body_n : array_like, shape (T, Z)
        Outward radial body force of each ball (centrifugal, weight), N.
    clearance_m : float or array_like, shape (T, Z)
        Radial clearance Delta_r (seed eq. 14), m; < 0 a preload. An array gives each ball its
        own at each instant (a defect under it, an out-of-round outer race).
    load_xy_n : array_like, shape (2,) or (T, 2)
        Load F on the inner ring, N (an array: at each instant).
    coefficients : (float, float)
        Normal-law coefficients c of the ball/inner and ball/outer raceway contacts.
    exponent : float
        Exponent n of the normal law: 1.5 (Hertz, Harris) or 1 (linear).
    rtol : float
        Residual |R| accepted, relative to the load carried F + sum Q_i.
    start_xy_m : array_like, shape (2,) or (T, 2)
        Shift the first instant starts from, or each instant's own start (instants far apart,
        whose extrapolation would start far off).
    """
    if exponent not in NORMAL_LAWS:
        raise ValueError(f"exponent = {exponent!r}: allowed {sorted(NORMAL_LAWS)}")
    ux = np.ascontiguousarray(ux, dtype=float)
    uy = np.ascontiguousarray(uy, dtype=float)
    body = np.ascontiguousarray(np.broadcast_to(body_n, ux.shape), dtype=float)
    ci, co = (float(c) for c in coefficients)
    n = float(exponent)
    n_instants, n_balls = ux.shape
    load = np.broadcast_to(np.asarray(load_xy_n, dtype=float), (n_instants, 2))
    fx, fy = np.ascontiguousarray(load[:, 0]), np.ascontiguousarray(load[:, 1])
    clearance = np.ascontiguousarray(np.broadcast_to(clearance_m, ux.shape), dtype=float)
    # Regularisation of a singular Jacobian (fewer than two balls squeezed): a small fraction of
    # the secant stiffness of Z balls carrying a representative load.
    largest = float(np.hypot(fx, fy).max(initial=0.0))
    ball_load = max(largest / n_balls, float(np.abs(body).max(initial=0.0)), 1.0)
    floor = 1e-10 * n_balls * ball_load / series_overlap_m(ball_load, (ci, co), n)
    out = (
        np.zeros((n_instants, 2)),
        *(np.zeros((n_instants, n_balls)) for _ in range(4)),
        np.zeros(n_instants, dtype=np.bool_),
    )
    if n_instants:
        start = np.ascontiguousarray(np.asarray(start_xy_m, dtype=float).reshape(-1, 2))
        _solve_series(ux, uy, body, clearance, fx, fy, ci, co, n, floor, rtol, start, out)
    return RingSolution(*out)
