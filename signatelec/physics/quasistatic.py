"""Quasi-static load distribution of the 2D radial ball bearing (Harris' theory).

The reference against which the DEM of the seed is validated, and the "quasi-static tier" that
replaces it where dynamics do not matter. Every function is pure and works on numpy arrays in SI.

Geometry and conventions (those of the DEM)
-------------------------------------------
- The outer ring centre is the origin and is fixed. The radial load ``F_r`` acts on the inner
  ring along ``-y``, like gravity (seed section 2.2.2).
- A ball angle ``psi`` is measured from the load direction ``-y``, counter-clockwise positive;
  the ball centre is ``r (sin psi, -cos psi)`` and ``u_psi = (sin psi, -cos psi)`` is the outward
  radial unit vector at the ball.
- ``clearance_m`` is the radial clearance ``Delta_r = R_out^f - R_out`` of seed eq. 14 (> 0
  clearance, < 0 preload). ``shift_xy_m`` is the displacement ``s`` of the inner-ring centre
  (``s_y < 0`` under load) and ``delta_r = |s|`` the radial shift of seed section 2.2.2.
- The radial approach of the rings at a ball is ``delta_psi = s . u_psi - Delta_r``; with
  ``s = (0, -delta_r)`` it is Harris' ``delta_r cos psi - P_d / 2`` with ``P_d = 2 Delta_r``.
- Each ball is a free body between the two races. Its outward radial body force is the
  centrifugal force ``F_c = m_b omega_c^2 r_p`` of its orbit at the cage speed, plus, when gravity
  is on, the radial component ``m_b g cos psi`` of its weight (the tangential component goes to
  the cage, which the quasi-static model does not resolve).

Array shapes: a ball set is ``ball_angle_rad`` of shape ``(Z,)`` (one instant) or ``(T, Z)``
(``[instant, ball]``); shifts are ``(2,)`` or ``(T, 2)`` (``[instant, xy]``).

References
----------
Seed: C. Machado, M. Guessasma, E. Bellenger, *Modelling of ball bearing loading by DEM for
electromechanical coupling*; equation numbers below are the seed's (eq. 14 clearance, eq. 15 load
parameter).
T. A. Harris, *Rolling Bearing Analysis*, 4th ed., Wiley, 2001: section 7.2 (load-deflection of a
ball between two raceways), section 7.3 and table 7.1 (radially loaded bearings, the radial
integral J_r(epsilon)), chapter 10 (centrifugal ball load at high speed).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.integrate import quad

from signatelec.config.bearing import INNER, OUTER, STANDARD_GRAVITY_M_S2, Bearing, raceway_radii
from signatelec.physics.contact import (
    hertz_elastic_energy,
    hertz_normal_force,
    hertz_normal_stiffness,
    hertz_overlap,
    law_coefficients,
    linear_elastic_energy,
    linear_normal_force,
)

#: Relative convergence of a ball's series deflection and of the ring equilibrium.
SOLVER_RTOL = 1e-12
#: Equilibrium residual, relative to the load carried, accepted when Newton stalls on round-off.
ACCEPTED_RTOL = 1e-9
_MAX_BALL_ITERATIONS = 200
_MAX_RING_ITERATIONS = 100
_MAX_HALVINGS = 60


# --- Harris' radial integral and the load parameter (seed eq. 15, Harris 7.3) ---------------------


def _load_zone_half_angle(epsilon):
    """psi_l = arccos(1 - 2 epsilon), pi when every ball is loaded (epsilon >= 1), 0 if none."""
    return np.arccos(np.clip(1.0 - 2.0 * np.asarray(epsilon, dtype=float), -1.0, 1.0))


def harris_radial_integral(epsilon, exponent=1.5):
    r"""Harris' radial integral J_r(epsilon) of a single-row bearing.

    .. math::

        J_r(\epsilon) = \frac{1}{2\pi} \int_{-\psi_l}^{\psi_l}
            \left[1 - \frac{1 - \cos\psi}{2\epsilon}\right]^n \cos\psi \, d\psi,
        \qquad \psi_l = \arccos(1 - 2\epsilon),

    so that ``F_r = Z Q_max J_r(epsilon)`` for many balls (Harris 2001, section 7.3, table 7.1).
    For ``epsilon >= 1`` the bracket stays positive over the whole circle (every ball loaded) and
    the integral runs over ``[-pi, pi]``; ``J_r = 0`` for ``epsilon <= 0``.

    Parameters
    ----------
    epsilon : float or array_like
        Load parameter (seed eq. 15), dimensionless.
    exponent : float
        Load-deflection exponent n: 1.5 for point (ball) contact, 1 for the linear law.

    Returns
    -------
    numpy.ndarray
        J_r, same shape as ``epsilon``.
    """
    eps = np.asarray(epsilon, dtype=float)
    flat_eps = eps.ravel()
    half_angle = _load_zone_half_angle(flat_eps)
    out = np.zeros(flat_eps.shape)
    for idx in np.flatnonzero(flat_eps > 0.0):
        e, psi_l = float(flat_eps[idx]), float(half_angle[idx])

        def integrand(psi, e=e):
            return max(1.0 - (1.0 - math.cos(psi)) / (2.0 * e), 0.0) ** exponent * math.cos(psi)

        # The integrand vanishes like (psi_l - psi)^n at the edge of the load zone: quad's
        # adaptive Gauss-Kronrod rule reaches ~1e-13 there.
        value, _ = quad(integrand, 0.0, psi_l, epsabs=1e-14, epsrel=1e-12, limit=200)
        out[idx] = value / math.pi
    return out.reshape(eps.shape)


def max_ball_load_n(radial_load_n, n_balls, epsilon, exponent=1.5):
    """Maximum ball load Q_max = F_r / (Z J_r(epsilon)) of the many-ball theory (Harris 7.3).

    At zero clearance (epsilon = 0.5, n = 1.5) this is Stribeck's ``Q_max = 4.37 F_r / Z``.
    """
    return np.asarray(radial_load_n, dtype=float) / (
        n_balls * harris_radial_integral(epsilon, exponent)
    )


def epsilon_from_shift(delta_r_m, clearance_m):
    r"""Load parameter epsilon = (1 - Delta_r / delta_r) / 2 (seed eq. 15).

    ``epsilon = 0.5`` at zero clearance for any shift (its limit as delta_r -> 0); with
    ``delta_r = 0`` a preload gives ``+inf`` (every ball equally loaded) and a clearance ``-inf``
    (no ball loaded).

    Parameters
    ----------
    delta_r_m : float or array_like
        Radial shift of the inner ring |s|, m.
    clearance_m : float or array_like
        Radial clearance Delta_r of seed eq. 14, m (< 0: preload).
    """
    delta_r = np.asarray(delta_r_m, dtype=float)
    clearance = np.asarray(clearance_m, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        eps = 0.5 * (1.0 - clearance / delta_r)
    return np.where(clearance == 0.0, 0.5, eps)


def load_zone_limit_rad(delta_r_m, clearance_m):
    """Load-zone half angle psi_l = arccos(Delta_r / delta_r) (seed 2.2.2; Harris 7.3).

    Geometric limit (the rings' approach is positive for |psi| < psi_l); pi when every ball is
    squeezed (preload beyond the shift), 0 when none is, pi/2 at zero clearance.
    """
    return _load_zone_half_angle(epsilon_from_shift(delta_r_m, clearance_m))


def ball_angles_rad(n_balls, cage_angle_rad=0.0):
    """Angles of Z evenly spaced balls, ball 0 at the cage angle: shape ``cage_angle.shape + (Z,)``.

    Passing the cage angle at T instants (``omega_c t``) gives the ``(T, Z)`` input of
    :func:`solve_equilibrium_over_time`.
    """
    cage = np.asarray(cage_angle_rad, dtype=float)[..., None]
    return cage + 2.0 * np.pi * np.arange(n_balls) / n_balls


def radial_unit_vectors(ball_angle_rad):
    """Outward radial unit vectors u_psi = (sin psi, -cos psi), shape ``angle.shape + (2,)``."""
    psi = np.asarray(ball_angle_rad, dtype=float)
    return np.stack((np.sin(psi), -np.cos(psi)), axis=-1)


# --- one ball between the races (Harris 7.2) ------------------------------------------------------


def _linear_stiffness(overlap_m, stiffness_n_m):
    return stiffness_n_m * (overlap_m > 0.0)


def _linear_overlap(force_n, stiffness_n_m):
    return np.maximum(force_n, 0.0) / stiffness_n_m


class _LawFunctions(NamedTuple):
    force: Callable  # (overlap_m, coefficient) -> N
    stiffness: Callable  # (overlap_m, coefficient) -> N/m
    energy: Callable  # (overlap_m, coefficient) -> J
    overlap: Callable  # (force_n, coefficient) -> m


# Per exponent, the contact laws of signatelec.physics.contact: the theory uses the DEM's own laws.
_LAW_FUNCTIONS = {
    1.5: _LawFunctions(
        hertz_normal_force, hertz_normal_stiffness, hertz_elastic_energy, hertz_overlap
    ),
    1.0: _LawFunctions(
        linear_normal_force, _linear_stiffness, linear_elastic_energy, _linear_overlap
    ),
}


@dataclass(frozen=True)
class RacewayLaw:
    """The elastic laws Q = c delta^n of the ball/inner and ball/outer raceway contacts."""

    inner_coefficient: float
    outer_coefficient: float
    exponent: float

    @classmethod
    def of(cls, bearing: Bearing, law: str = "hertz", linear_stiffness_n_m=None) -> RacewayLaw:
        """The raceway laws of a bearing under a contact law of :func:`law_coefficients`."""
        coefficients, exponent = law_coefficients(bearing, law, linear_stiffness_n_m)
        return cls(float(coefficients[INNER]), float(coefficients[OUTER]), float(exponent))

    def __post_init__(self) -> None:
        if self.exponent not in _LAW_FUNCTIONS:
            raise ValueError(f"exponent = {self.exponent!r}: allowed {sorted(_LAW_FUNCTIONS)}")

    def force(self, overlap_m, coefficient):
        return _LAW_FUNCTIONS[self.exponent].force(overlap_m, coefficient)

    def stiffness(self, overlap_m, coefficient):
        return _LAW_FUNCTIONS[self.exponent].stiffness(overlap_m, coefficient)

    def energy(self, overlap_m, coefficient):
        return _LAW_FUNCTIONS[self.exponent].energy(overlap_m, coefficient)

    def overlap(self, force_n, coefficient):
        return _LAW_FUNCTIONS[self.exponent].overlap(force_n, coefficient)

    def series_approach(self, inner_force_n, outer_force_n):
        """Approach d_i + d_o of a ball carrying these forces on its inner and outer race, m."""
        return self.overlap(inner_force_n, self.inner_coefficient) + self.overlap(
            outer_force_n, self.outer_coefficient
        )


def _solve_both_contacts(approach_m, body_force_n, law: RacewayLaw):
    """Inner deflection x in (0, delta) with c_i x^n + b = c_o (delta - x)^n, m.

    The residual is increasing in x and changes sign on [0, delta], so Newton steps are kept
    inside a bracket that every evaluation narrows, with bisection when Newton leaves it.
    """
    ci, co = law.inner_coefficient, law.outer_coefficient
    lo = np.zeros_like(approach_m)
    hi = approach_m.copy()
    # Without body force the split is exact: the unit-force deflections are in the ratio.
    di1, do1 = law.overlap(1.0, ci), law.overlap(1.0, co)
    x = approach_m * (di1 / (di1 + do1))
    for _ in range(_MAX_BALL_ITERATIONS):
        outer = approach_m - x
        residual = law.force(x, ci) + body_force_n - law.force(outer, co)
        slope = law.stiffness(x, ci) + law.stiffness(outer, co)
        lo = np.where(residual < 0.0, x, lo)
        hi = np.where(residual > 0.0, x, hi)
        x_new = x - residual / slope
        x_new = np.where((x_new > lo) & (x_new < hi), x_new, 0.5 * (lo + hi))
        done = (np.abs(x_new - x) <= SOLVER_RTOL * x_new) | (
            hi - lo <= 4.0 * np.finfo(float).eps * approach_m
        )
        x = x_new
        if done.all():
            return x
    raise RuntimeError("ball series deflection did not converge")  # pragma: no cover


def _ball_state(approach_m, body_force_n, law: RacewayLaw):
    """Forces, tangent stiffness and potential of balls squeezed between the races.

    Returns ``(inner_force_n, outer_force_n, stiffness_n_m, potential_j)``, each of the broadcast
    shape of the inputs. ``stiffness_n_m = dQ_i / d delta`` (the two contacts in series, Harris
    7.2; zero when the ball touches one race only) and ``potential_j`` has derivative ``Q_i``
    with respect to the approach: the ball's elastic energy minus the work of its body force.
    """
    approach, body = np.broadcast_arrays(
        np.asarray(approach_m, dtype=float), np.asarray(body_force_n, dtype=float)
    )
    ci, co = law.inner_coefficient, law.outer_coefficient
    both = (
        (approach > 0.0)
        & (law.force(approach, co) > body)  # the ball, pressed outward, reaches the inner race
        & (law.force(approach, ci) > -body)  # the ball, pressed inward, reaches the outer race
    )
    # A ball touching one race only rests on the race its body force presses it against. x is the
    # inner deflection: negative (a gap) when the ball rests on the outer race.
    x = np.where(
        body > 0.0,
        approach - law.overlap(body, co),
        np.where(body < 0.0, law.overlap(-body, ci), 0.5 * np.minimum(approach, 0.0)),
    )
    if both.any():
        x[both] = _solve_both_contacts(approach[both], body[both], law)
    outer = approach - x
    inner_force = law.force(x, ci)
    outer_force = law.force(outer, co)
    ki, ko = law.stiffness(x, ci), law.stiffness(outer, co)
    stiffness = np.where(both, ki * ko / np.where(both, ki + ko, 1.0), 0.0)
    potential = law.energy(x, ci) + law.energy(outer, co) - body * outer
    return inner_force, outer_force, stiffness, potential


def ball_body_force_n(
    ball_angle_rad, bearing: Bearing, omega_rad_s, centrifugal=True, gravity=False
):
    r"""Outward radial body force on each ball, N.

    .. math:: b(\psi) = m_b \omega_c^2 r_p + m_b g \cos\psi

    The centrifugal term (Harris 2001, chapter 10) uses the kinematic cage speed
    ``omega_c = bearing.cage_speed_rad_s(omega)`` and the pitch radius; the gravity term is the
    radial component of the ball weight along ``-y`` (seed section 2.2.2 loads like gravity).
    """
    psi = np.asarray(ball_angle_rad, dtype=float)
    body = np.zeros(psi.shape)
    if centrifugal:
        omega_c = bearing.cage_speed_rad_s(omega_rad_s)
        body = body + bearing.ball_mass_kg * omega_c**2 * bearing.pitch_radius_m
    if gravity:
        body = body + bearing.ball_mass_kg * STANDARD_GRAVITY_M_S2 * np.cos(psi)
    return body


def ball_loads(
    ball_angle_rad,
    shift_xy_m,
    bearing: Bearing,
    clearance_m,
    omega_rad_s,
    law="hertz",
    centrifugal=True,
    gravity=False,
    linear_stiffness_n_m=None,
):
    r"""Inner and outer raceway forces of every ball for a given inner-ring shift.

    Each ball sees the approach ``delta_psi = s . u_psi - Delta_r`` and carries its outward body
    force b (:func:`ball_body_force_n`). When it touches both races the two contacts are in
    series (Harris 2001, section 7.2):

    .. math:: d_i + d_o = \delta_\psi, \qquad Q_o = Q_i + b, \qquad Q = c\, d^n,

    solved per ball by bracketed Newton to 1e-12 relative. A ball that cannot reach the other
    race (``delta_psi < d_o(b)`` for ``b > 0``) carries ``Q_i = 0, Q_o = b``; for ``b < 0``
    (gravity on an upper ball at rest) ``Q_o = 0, Q_i = -b``.

    Parameters
    ----------
    ball_angle_rad : array_like, shape (..., Z)
        Ball angles psi from the load direction -y, counter-clockwise, rad.
    shift_xy_m : array_like, shape (..., 2)
        Inner-ring centre displacement s, m.
    bearing : Bearing
        Geometry, materials and masses.
    clearance_m : float
        Radial clearance Delta_r (seed eq. 14), m; < 0 is a preload.
    omega_rad_s : float
        Inner-ring speed, rad/s (sets the cage speed of the centrifugal force).
    law : {"hertz", "harris", "linear"}
        Contact law of :func:`signatelec.physics.contact.law_coefficients`.
    centrifugal, gravity : bool
        Body forces on the balls.
    linear_stiffness_n_m : float, optional
        Ball/outer-raceway stiffness of the linear law.

    Returns
    -------
    inner_force_n, outer_force_n : numpy.ndarray, shape (..., Z)
    """
    raceway = RacewayLaw.of(bearing, law, linear_stiffness_n_m)
    u = radial_unit_vectors(ball_angle_rad)
    approach = np.einsum("...zk,...k->...z", u, np.asarray(shift_xy_m, dtype=float))
    body = ball_body_force_n(ball_angle_rad, bearing, omega_rad_s, centrifugal, gravity)
    inner, outer, _, _ = _ball_state(approach - clearance_m, body, raceway)
    return inner, outer


# --- equilibrium of the inner ring ----------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class QuasiStaticState:
    """Equilibrium of the inner ring, for one instant or a time series.

    Shapes are those of one instant, with a leading ``T`` axis for a time series.

    Attributes
    ----------
    shift_xy_m : (2,) or (T, 2)
        Inner-ring centre displacement s, m.
    delta_r_m : () or (T,)
        Radial shift |s| (seed 2.2.2), m.
    epsilon : () or (T,)
        Load parameter of seed eq. 15 from delta_r and the clearance.
    load_zone_limit_rad : () or (T,)
        Geometric load-zone half angle arccos(Delta_r / delta_r), about the direction of s.
    inner_force_n, outer_force_n : (Z,) or (T, Z)
        Ball/inner and ball/outer raceway forces, N.
    loaded_count : () or (T,)
        Balls carrying an inner-raceway force (Q_i > 0). With the centrifugal force it can fall
        short of the geometric load zone: a ball needs delta_psi > d_o(F_c) to reach the inner race.
    """

    shift_xy_m: np.ndarray
    delta_r_m: np.ndarray
    epsilon: np.ndarray
    load_zone_limit_rad: np.ndarray
    inner_force_n: np.ndarray
    outer_force_n: np.ndarray
    loaded_count: np.ndarray

    @property
    def max_inner_force_n(self):
        """Q_max, the largest ball/inner-raceway force, N."""
        return self.inner_force_n.max(axis=-1)


def _ring_state(shift, u, body, clearance_m, load_xy, raceway):
    """Ball forces, residual, potential and Jacobian of the ring equilibrium at shifts (T, 2).

    Residual ``R = sum_k Q_i,k u_k - F`` is the gradient of the convex potential
    ``sum_k E_k(delta_k) - F . s``; its Jacobian is ``sum_k k_k u_k u_k^T``.
    """
    approach = np.einsum("tzk,tk->tz", u, shift) - clearance_m
    inner, outer, stiffness, potential = _ball_state(approach, body, raceway)
    residual = np.einsum("tz,tzk->tk", inner, u) - load_xy
    total_potential = potential.sum(axis=-1) - shift @ load_xy
    jacobian = np.einsum("tz,tzi,tzj->tij", stiffness, u, u)
    return inner, outer, residual, total_potential, jacobian


def _cold_start(u, body, clearance_m, load_xy, raceway):
    """A shift along the load that squeezes at least the two balls nearest the load direction.

    Each of them gets the approach of a ball carrying 5 F / Z (Stribeck's design value) on top of
    any clearance, so the first Jacobian is not singular even with a large clearance.
    """
    n_instants, n_balls = u.shape[:2]
    load = float(np.hypot(*load_xy))
    if load == 0.0:
        return np.zeros((n_instants, 2))
    direction = load_xy / load
    second = np.sort(u @ direction, axis=-1)[:, -2]
    ball_load = 5.0 * load / n_balls
    approach = raceway.series_approach(ball_load, ball_load + max(float(body.max()), 0.0))
    magnitude = (max(clearance_m, 0.0) + approach) / np.clip(second, 0.1, 1.0)
    return magnitude[:, None] * direction


def _equilibrium(u, body, clearance_m, load_xy, raceway, initial_shift):
    """Damped Newton on every instant at once; returns the shifts (T, 2) and the ball forces."""
    n_instants, n_balls = u.shape[:2]
    load = float(np.hypot(*load_xy))
    # Regularisation of a singular Jacobian (fewer than two balls squeezed): a small fraction of
    # the secant stiffness of Z balls carrying a representative load.
    ball_load = max(load / n_balls, float(np.abs(body).max(initial=0.0)), 1.0)
    floor = 1e-10 * n_balls * ball_load / raceway.series_approach(ball_load, ball_load)

    shift = np.array(initial_shift, dtype=float)
    inner, outer, residual, potential, jacobian = _ring_state(
        shift, u, body, clearance_m, load_xy, raceway
    )

    def converged(rows, rtol):
        # Relative to the load carried, but not below the round-off of the approaches
        # s . u - Delta_r, which loses digits when the deflections are tiny beside the clearance.
        res, jac, sh = residual[rows], jacobian[rows], shift[rows]
        roundoff = (
            16.0
            * np.finfo(float).eps
            * (np.hypot(sh[:, 0], sh[:, 1]) + abs(clearance_m))
            * (jac[:, 0, 0] + jac[:, 1, 1])
        )
        allowed = np.maximum(rtol * (load + inner[rows].sum(axis=-1)), roundoff)
        return np.hypot(res[:, 0], res[:, 1]) <= allowed

    done = converged(slice(None), SOLVER_RTOL)
    for _ in range(_MAX_RING_ITERATIONS):
        rows = np.flatnonzero(~done)
        if rows.size == 0:
            break
        jac = jacobian[rows]
        trace = jac[:, 0, 0] + jac[:, 1, 1]
        jac = jac + (1e-12 * trace + floor)[:, None, None] * np.eye(2)
        res = residual[rows]
        det = jac[:, 0, 0] * jac[:, 1, 1] - jac[:, 0, 1] * jac[:, 1, 0]
        step = (
            -np.stack(
                (
                    jac[:, 1, 1] * res[:, 0] - jac[:, 0, 1] * res[:, 1],
                    jac[:, 0, 0] * res[:, 1] - jac[:, 1, 0] * res[:, 0],
                ),
                axis=-1,
            )
            / det[:, None]
        )
        slope = np.einsum("tk,tk->t", res, step)  # < 0: the regularised Jacobian is positive
        res_norm = np.hypot(res[:, 0], res[:, 1])
        # Backtracking: accept a step that lowers the convex potential (Armijo) or, near the
        # solution where the potential is flat to round-off, that lowers the residual.
        t = np.ones(rows.size)
        pending = np.ones(rows.size, dtype=bool)
        for _ in range(_MAX_HALVINGS):
            sub = rows[pending]
            trial = shift[sub] + t[pending, None] * step[pending]
            state = _ring_state(trial, u[sub], body[sub], clearance_m, load_xy, raceway)
            new_res_norm = np.hypot(state[2][:, 0], state[2][:, 1])
            ok = (state[3] <= potential[sub] + 1e-4 * t[pending] * slope[pending]) | (
                new_res_norm <= (1.0 - 1e-4 * t[pending]) * res_norm[pending]
            )
            accepted = sub[ok]
            shift[accepted] = trial[ok]
            for full, part in zip(
                (inner, outer, residual, potential, jacobian), state, strict=True
            ):
                full[accepted] = part[ok]
            idx = np.flatnonzero(pending)
            pending[idx[ok]] = False
            t[idx[~ok]] *= 0.5
            if not pending.any():
                break
        # Newton steps at round-off level (relative to the shift) end the iteration as well.
        tiny_step = np.hypot(step[:, 0], step[:, 1]) <= 4.0 * np.finfo(float).eps * np.hypot(
            shift[rows, 0], shift[rows, 1]
        )
        done[rows] = converged(rows, SOLVER_RTOL) | tiny_step | pending
    bad = ~converged(slice(None), ACCEPTED_RTOL)
    if bad.any():
        raise RuntimeError(
            f"ring equilibrium not reached at {int(bad.sum())} of {n_instants} instants "
            f"(first: {int(np.flatnonzero(bad)[0])}; residual "
            f"{float(np.hypot(*residual[bad][0])):.3g} N for a load of {load:.6g} N)"
        )
    return shift, inner, outer


def _ball_set_carries(ball_angle_rad, load_xy):
    """Whether each instant's balls can carry the load: F must lie in the cone of the u_k.

    Contact forces only push (Q_i >= 0), so balls all within less than a half turn of one another
    and away from the load direction cannot balance it, whatever the shift.
    """
    load_angle = math.atan2(load_xy[0], -load_xy[1])  # psi of the load direction
    theta = np.angle(np.exp(1j * (ball_angle_rad - load_angle)))  # in (-pi, pi]
    ahead = np.where(theta > 0.0, theta, np.inf).min(axis=-1)
    behind = np.where(theta < 0.0, theta, -np.inf).max(axis=-1)
    return (ahead - behind < np.pi) | (np.abs(theta) <= 1e-12).any(axis=-1)


def _ring_load_xy(bearing, radial_load_n, gravity):
    weight = bearing.inner_ring_mass_kg * STANDARD_GRAVITY_M_S2 if gravity else 0.0
    return np.array([0.0, -(float(radial_load_n) + weight)])


def _state(shift, inner, outer, clearance_m) -> QuasiStaticState:
    delta_r = np.hypot(shift[..., 0], shift[..., 1])
    return QuasiStaticState(
        shift_xy_m=shift,
        delta_r_m=delta_r,
        epsilon=epsilon_from_shift(delta_r, clearance_m),
        load_zone_limit_rad=load_zone_limit_rad(delta_r, clearance_m),
        inner_force_n=inner,
        outer_force_n=outer,
        loaded_count=np.count_nonzero(inner > 0.0, axis=-1),
    )


def solve_equilibrium_over_time(
    ball_angle_rad,
    bearing: Bearing,
    radial_load_n,
    clearance_m,
    omega_rad_s,
    law="hertz",
    centrifugal=True,
    gravity=False,
    linear_stiffness_n_m=None,
    initial_shift_xy_m=None,
) -> QuasiStaticState:
    r"""Quasi-static equilibrium of the inner ring at each of T instants.

    Solves, at every instant, the 2D equilibrium of the inner ring

    .. math:: \sum_k Q_{i,k}(s)\, u_k = F, \qquad F = (0, -F_r - m_{ring} g\,[\text{gravity}])

    for the shift s, with the ball forces of :func:`ball_loads` (Harris 2001, section 7.3, in 2D
    and for arbitrary ball angles). The residual is the gradient of a convex potential (elastic
    energy minus the work of the load), so Newton on the analytic Jacobian
    ``sum_k (dQ_i,k / d delta_k) u_k u_k^T``, damped by backtracking on that potential, is
    globally convergent. It starts from a shift that squeezes at least two balls, so a large
    clearance (few balls loaded) is handled, and the Jacobian is regularised while singular.

    All instants are iterated together (one vectorised Newton), started from the solution of the
    first instant: the load is the same, only the ball angles move, so a few iterations suffice
    (instants where that start squeezes fewer than two balls start as the first one did).
    A (1000, 13) input takes a few tens of milliseconds.

    Special cases: with F = 0 and a clearance (or zero clearance) no ball needs to touch the inner
    race and the ring position is indeterminate within the clearance; the centred solution
    ``s = 0`` is returned (all ``Q_i = 0``). With F = 0 and a preload every ball is squeezed and
    ``s`` is determinate (0 for a symmetric ball set).

    Parameters
    ----------
    ball_angle_rad : array_like, shape (T, Z)
        Ball angles psi from -y, counter-clockwise, rad.
    bearing, clearance_m, omega_rad_s, law, centrifugal, linear_stiffness_n_m
        As in :func:`ball_loads`.
    radial_load_n : float
        Radial load F_r along -y on the inner ring (seed section 2.2.2), N; >= 0.
    gravity : bool
        Weight of the balls (radial component, in their body force) and of the inner ring.
    initial_shift_xy_m : array_like, shape (2,), optional
        Start of the first instant (e.g. the previous solution of a time-stepping caller).

    Returns
    -------
    QuasiStaticState
        With a leading T axis.

    Raises
    ------
    ValueError
        If at some instant the balls all lie on one side, away from the load (contact forces only
        push, so no shift can balance it).
    RuntimeError
        If some instant does not reach ``|R| <= 1e-9 (F + sum Q_i)`` (or the round-off floor of
        the approaches). Physical ball sets converge to 1e-12; nearly coincident balls, which a
        real cage forbids, make the sideways equilibrium ill-conditioned.
    """
    psi = np.asarray(ball_angle_rad, dtype=float)
    if psi.ndim != 2 or psi.shape[1] < 3:
        raise ValueError(f"ball_angle_rad: shape (T, Z) with Z >= 3 expected, got {psi.shape}")
    if not np.isfinite(radial_load_n) or radial_load_n < 0.0:
        raise ValueError(f"radial_load_n = {radial_load_n!r}: must be a finite number >= 0")
    raceway = RacewayLaw.of(bearing, law, linear_stiffness_n_m)
    load_xy = _ring_load_xy(bearing, radial_load_n, gravity)
    if load_xy.any():
        carries = _ball_set_carries(psi, load_xy)
        if not carries.all():
            bad = np.flatnonzero(~carries)
            raise ValueError(
                f"ball_angle_rad: at {bad.size} of {psi.shape[0]} instants (first: {bad[0]}) the "
                "balls lie on one side, away from the load, and cannot carry it"
            )
    u = radial_unit_vectors(psi)
    body = ball_body_force_n(psi, bearing, omega_rad_s, centrifugal, gravity)

    first = (
        np.asarray(initial_shift_xy_m, dtype=float)[None, :]
        if initial_shift_xy_m is not None
        else _cold_start(u[:1], body[:1], clearance_m, load_xy, raceway)
    )
    first_shift, _, _ = _equilibrium(u[:1], body[:1], clearance_m, load_xy, raceway, first)
    start = np.repeat(first_shift, psi.shape[0], axis=0)
    if psi.shape[0] > 1:
        approach = np.einsum("tzk,tk->tz", u, start) - clearance_m
        squeezed = np.count_nonzero(_ball_state(approach, body, raceway)[2] > 0.0, axis=-1)
        cold = squeezed < 2
        if cold.any():
            start[cold] = _cold_start(u[cold], body[cold], clearance_m, load_xy, raceway)
    shift, inner, outer = _equilibrium(u, body, clearance_m, load_xy, raceway, start)
    return _state(shift, inner, outer, clearance_m)


def solve_equilibrium(
    ball_angle_rad,
    bearing: Bearing,
    radial_load_n,
    clearance_m,
    omega_rad_s,
    law="hertz",
    centrifugal=True,
    gravity=False,
    linear_stiffness_n_m=None,
    initial_shift_xy_m=None,
) -> QuasiStaticState:
    """Quasi-static equilibrium of the inner ring for one ball set of shape (Z,).

    See :func:`solve_equilibrium_over_time` for the equations, the method and the special cases
    (F_r = 0 with a clearance returns the centred, indeterminate solution s = 0).
    """
    psi = np.asarray(ball_angle_rad, dtype=float)
    if psi.ndim != 1:
        raise ValueError(f"ball_angle_rad: shape (Z,) expected, got {psi.shape}")
    state = solve_equilibrium_over_time(
        psi[None, :],
        bearing,
        radial_load_n,
        clearance_m,
        omega_rad_s,
        law=law,
        centrifugal=centrifugal,
        gravity=gravity,
        linear_stiffness_n_m=linear_stiffness_n_m,
        initial_shift_xy_m=initial_shift_xy_m,
    )
    return QuasiStaticState(**{k: v[0] for k, v in vars(state).items()})


#: The bearing's regimes by its radial clearance Delta_r (seed eq. 14): "preload" below
#: -REGIME_TOLERANCE_M, "zero" within +-REGIME_TOLERANCE_M, "clearance" above; epsilon
#: (seed eq. 15) is above 0.5, 0.5 and below 0.5 in turn (:func:`regime_of`).
REGIMES = ("preload", "zero", "clearance")
REGIME_TOLERANCE_M = 1e-6


def regime_of(clearance_m: float) -> str:
    """The regime (:data:`REGIMES`) of a radial clearance in metres."""
    if clearance_m < -REGIME_TOLERANCE_M:
        return "preload"
    if clearance_m > REGIME_TOLERANCE_M:
        return "clearance"
    return "zero"


def clearance_for_epsilon(
    bearing, radial_load_n: float, omega_rad_s: float, epsilon: float
) -> float:
    """Radial clearance (m) giving load parameter ``epsilon`` (seed eq. 15) at ``radial_load_n``.

    Quasi-static Hertz equilibrium (signatelec.physics.quasistatic) with the centrifugal force and
    gravity, averaged over the ball positions of one ball spacing; epsilon falls monotonically
    as the clearance grows, so a bracketing root finder is safe. For the seed's 6208 at 5820 N
    and 500 rad/s, epsilon = 0.3 needs about +47 um.
    """
    from scipy.optimize import brentq

    z = bearing.n_balls
    cage = np.linspace(0.0, 2.0 * math.pi / z, 8, endpoint=False)
    angles = ball_angles_rad(z, cage)

    def excess(clearance_m: float) -> float:
        state = solve_equilibrium_over_time(
            angles,
            bearing,
            radial_load_n,
            clearance_m,
            omega_rad_s,
            centrifugal=True,
            gravity=True,
        )
        return float(np.mean(state.epsilon)) - epsilon

    if not 0.0 < epsilon < 0.5:
        raise ValueError(f"epsilon = {epsilon!r}: a clearance gives 0 < epsilon < 0.5")
    upper = 0.05 * bearing.ball_radius_m  # the largest clearance a scene accepts
    return float(brentq(excess, 1e-9, upper, xtol=1e-10))


#: Maximum Hertz contact pressure a ball bearing takes statically (ISO 76), Pa.
STATIC_PRESSURE_LIMIT_PA = 4.2e9


def preload_limit_m(bearing) -> float:
    """Largest preload (-clearance) whose ball load keeps p0 = 3 Q / (2 pi a b) <= 4.2 GPa.

    The contact ellipse is Hamrock-Brewe's (seed eqs 17-18); the load from the Hertz law
    (eq. 8) with inner and outer contacts in series.
    """
    from signatelec.physics.electrical import contact_ellipse

    coef, n = law_coefficients(bearing, "hertz")
    radii = raceway_radii(bearing)
    e_eq = bearing.ball_material.plane_strain_modulus_pa
    q_ref = 1000.0
    q_limit = math.inf
    for race in ("inner", "outer"):
        _, _, r_eq, alpha = radii[race]
        _, _, area = contact_ellipse(q_ref, r_eq, alpha, e_eq)
        p0 = 1.5 * q_ref / area
        q_limit = min(q_limit, q_ref * (STATIC_PRESSURE_LIMIT_PA / p0) ** 3)  # p0 ~ Q^(1/3)
    compliance = coef[INNER] ** (-1.0 / n) + coef[OUTER] ** (-1.0 / n)
    return q_limit ** (1.0 / n) * compliance
