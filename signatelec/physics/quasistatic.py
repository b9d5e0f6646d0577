"""Quasi-static load distribution of the 2D radial ball bearing (Harris' theory).

The reference against which the DEM of the seed is validated, and the equations of the
quasi-static tier that replaces it where dynamics do not matter. Every function is pure and
works on numpy arrays in SI. The ring equilibrium is solved by
:mod:`signatelec.physics.ring_equilibrium` (the tier calls the same solver); the closed forms
of the many-ball theory (J_r, epsilon, the load zone) are in
:mod:`signatelec.physics.load_distribution`.

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
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from signatelec.config.bearing import INNER, OUTER, STANDARD_GRAVITY_M_S2, Bearing, raceway_radii
from signatelec.physics.contact import hertz_overlap, law_coefficients
from signatelec.physics.load_distribution import epsilon_from_shift, load_zone_limit_rad

if TYPE_CHECKING:  # the compiled solver is loaded where it is used: validating a scene needs
    # the preload limit of this module, not the solver (numba)
    from signatelec.physics.ring_equilibrium import RingSolution

#: Equilibrium residual asked of the theory, relative to the load carried; a ball's series
#: deflection is converged to ~1e-14 (signatelec.physics.ring_equilibrium).
SOLVER_RTOL = 1e-12


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


def raceway_law(bearing: Bearing, law: str = "hertz", linear_stiffness_n_m=None):
    """``((c_inner, c_outer), exponent)``: the ball/raceway laws Q = c d^n of a contact law
    (:func:`signatelec.physics.contact.law_coefficients`)."""
    coefficients, exponent = law_coefficients(bearing, law, linear_stiffness_n_m)
    return (float(coefficients[INNER]), float(coefficients[OUTER])), float(exponent)


def ball_body_force_n(
    ball_angle_rad,
    bearing: Bearing,
    omega_rad_s,
    centrifugal=True,
    gravity=False,
    cage="none",
):
    r"""Outward radial body force on each ball, N.

    .. math:: b(\psi) = m_b \omega_c^2 r_p + m_b g \cos\psi \; [+ \text{cage}]

    The centrifugal term (Harris 2001, chapter 10) uses the kinematic cage speed
    ``omega_c = bearing.cage_speed_rad_s(omega)`` and the pitch radius; the gravity term is the
    radial component of the ball weight along ``-y`` (seed section 2.2.2 loads like gravity);
    with gravity, ``cage`` (the scene's ``effects.cage``) adds what the cage that carries the
    tangential part of the weights pushes on the balls: the seed's cage-ball chain
    (:func:`cage_chain_force_n`) or the rigid cage (:func:`rigid_cage_force_n`).
    """
    psi = np.asarray(ball_angle_rad, dtype=float)
    body = np.zeros(psi.shape)
    if centrifugal:
        omega_c = bearing.cage_speed_rad_s(omega_rad_s)
        body = body + bearing.ball_mass_kg * omega_c**2 * bearing.pitch_radius_m
    if gravity:
        body = body + bearing.ball_mass_kg * STANDARD_GRAVITY_M_S2 * np.cos(psi)
        if cage == "balls":
            body = body + cage_chain_force_n(psi, bearing)
        elif cage == "rigid":
            body = body + rigid_cage_force_n(psi, bearing)
    return body


def rigid_cage_force_n(ball_angle_rad, bearing: Bearing) -> np.ndarray:
    r"""Outward radial push, N, of the rigid cage's pockets on each ball under gravity.

    The rigid cage (one ball-guided ring with a spherical pocket of radial clearance
    ``c = pocket_clearance_m / 2`` per ball) sinks by Delta under gravity. Each ball, held on its
    radius by the races, slides along its tangent under ``-m_b g sin psi_k`` until the pocket
    wall holds it (overlaps of microns against c = 0.127 mm: rigid contacts). The pocket centre
    then lies ``a_k = Delta cos psi_k`` off the ball's radius, so the wall there is inclined and
    the frictionless reaction that holds the tangential weight also pushes the ball outward by

    .. math:: f_k = m_b g |\sin\psi_k| \, a_k / \sqrt{c^2 - a_k^2}

    (in above the axis, out below). The cage is in equilibrium when those pushes hold it and its
    weight: ``sum_k f_k cos psi_k = (m_c + Z m_b / 2) g`` (the tangential weights, Z m_b g / 2
    down in all, come back through the ring), which fixes Delta (bisection; the left side grows
    with Delta without bound as the most vertical pocket closes its clearance). Measured in the
    DEM at F_r = 0 (6208, 10 rad/s): the cage sinks 125.9 um for c = 127 um. Friction at the
    races, which may carry part of the weights, is left out.

    A ball at the very top or bottom (psi = 0 or pi) holds no tangential weight: when the other
    pockets cannot hold the cage, it sinks by the whole c and the vertical pockets close, carrying
    the rest of the weight straight down (shared among them). The bisection runs on the log of
    the gap left to that closure, c(1 - |cos psi_k| / max|cos psi|) + g |cos psi_k| computed without
    cancellation, so a pocket that closes to 1e-40 m (sin psi ~ 1e-16 at psi = pi) is resolved
    and no push overflows.
    """
    psi = np.asarray(ball_angle_rad, dtype=float)
    g = STANDARD_GRAVITY_M_S2
    c = 0.5 * bearing.pocket_clearance_m
    cos, sin = np.cos(psi), np.abs(np.sin(psi))
    weight = bearing.ball_mass_kg * g
    needed = (bearing.rigid_cage_mass_kg + 0.5 * psi.shape[-1] * bearing.ball_mass_kg) * g
    steepest = np.abs(cos).max(axis=-1, keepdims=True)
    high = c / steepest  # the sink at which the most vertical pocket closes
    open_share = 1.0 - np.abs(cos) / steepest  # >= 0; exactly 0 for the most vertical pockets

    def pushes(gap):  # gap = high - Delta, the sink left before the most vertical pocket closes
        a = (high - gap) * cos
        room = (c * open_share + gap * np.abs(cos)) * (c + np.abs(a))  # c^2 - a^2
        return weight * sin * a / np.sqrt(np.maximum(room, 1e-300))

    log_low = np.log(high[..., 0]) - 690.0  # a gap of e^-690 ~ 1e-300 of c: closed
    log_high = np.log(high[..., 0])
    for _ in range(80):  # bisection on log(gap) to ~1e-21 of its range
        mid = 0.5 * (log_low + log_high)
        short = (pushes(np.exp(mid)[..., None]) * cos).sum(axis=-1) < needed
        log_low, log_high = np.where(short, log_low, mid), np.where(short, mid, log_high)
    push = pushes(np.exp(0.5 * (log_low + log_high))[..., None])
    # what the inclined walls leave goes through the closed vertical pockets, straight down
    rest = needed - (push * cos).sum(axis=-1, keepdims=True)
    vertical = open_share <= 1e-12
    share = np.where(vertical, 1.0 / vertical.sum(axis=-1, keepdims=True), 0.0)
    return push + np.where(vertical & (rest > 0.0), rest * share / cos, 0.0)


def cage_chain_force_n(ball_angle_rad, bearing: Bearing) -> np.ndarray:
    r"""Outward radial push, N, of the seed's cage-ball chain on each ball under gravity.

    Balls and cage balls alternate on the pitch circle (seed section 2.1: each cage ball between
    two frictionless boundaries, so it carries no radial force to the ball set). The tangential
    part of each ball's weight, ``-m_b g sin psi_k``, slides it toward the bottom; the chain
    carries it: the compression of the gap after ball k is
    ``N_k = N_{k-1} - m_b g sin psi_k / cos(pi / 2Z)`` (balls in angle order), the
    constant fixed by the chain being slack where it is least compressed (it cannot pull).
    The ball/cage-ball contact lies along the chord to the cage ball, pi/(2Z) off the tangent,
    so each gap pushes the ball outward by ``N sin(pi / 2Z)``. Light loads only: at zero radial
    load the pushes (0.08 N on the bottom ball of a 6208) are as large as the ball weights
    themselves; the friction of the races, which may carry part of the weights, is left out
    (rolling balls: the drive torque the DEM measures there is ~0).
    """
    psi = np.asarray(ball_angle_rad, dtype=float)
    z = psi.shape[-1]
    half = math.pi / (2 * z)
    weight = bearing.ball_mass_kg * STANDARD_GRAVITY_M_S2
    order = np.argsort(np.remainder(psi, 2.0 * math.pi), axis=-1)
    ordered = np.take_along_axis(psi, order, axis=-1)
    gaps = np.cumsum(-weight * np.sin(ordered) / math.cos(half), axis=-1)  # gap after ball k
    gaps = gaps - gaps.min(axis=-1, keepdims=True)
    push = (gaps + np.roll(gaps, 1, axis=-1)) * math.sin(half)
    out = np.empty_like(push)
    np.put_along_axis(out, order, push, axis=-1)
    return out


def ring_load_xy_n(bearing: Bearing, radial_load_n, gravity=False) -> np.ndarray:
    """Load on the inner ring, (0, -(F_r + m_ring g [gravity])), N (seed 2.2.2: along -y)."""
    weight = bearing.inner_ring_mass_kg * STANDARD_GRAVITY_M_S2 if gravity else 0.0
    return np.array([0.0, -(float(radial_load_n) + weight)])


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

    solved per ball by safeguarded Newton to ~1e-14 of the deflection. A ball that cannot reach
    the other race (``delta_psi < d_o(b)`` for ``b > 0``) carries ``Q_i = 0, Q_o = b``; for
    ``b < 0`` (gravity on an upper ball at rest) ``Q_o = 0, Q_i = -b``.

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
    (ci, co), exponent = raceway_law(bearing, law, linear_stiffness_n_m)
    u = radial_unit_vectors(ball_angle_rad)
    approach = np.einsum("...zk,...k->...z", u, np.asarray(shift_xy_m, dtype=float)) - clearance_m
    body = ball_body_force_n(ball_angle_rad, bearing, omega_rad_s, centrifugal, gravity)
    approach, body = (
        np.ascontiguousarray(a, dtype=float) for a in np.broadcast_arrays(approach, body)
    )
    from signatelec.physics.ring_equilibrium import ball_forces

    inner, outer = np.zeros(approach.shape), np.zeros(approach.shape)
    ball_forces(approach.ravel(), body.ravel(), ci, co, exponent, inner.ravel(), outer.ravel())
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


def _ball_set_carries(ball_angle_rad, load_xy):
    """Whether each instant's balls can carry the load: F must lie in the cone of the u_k.

    Contact forces only push (Q_i >= 0), so balls all within less than a half turn of one another
    and away from the load direction cannot balance it, whatever the shift.
    """
    load_angle = math.atan2(load_xy[0], -load_xy[1])  # psi of the load direction
    theta = np.remainder(ball_angle_rad - load_angle + np.pi, 2.0 * np.pi) - np.pi  # [-pi, pi)
    ahead = np.where(theta > 0.0, theta, np.inf).min(axis=-1)
    behind = np.where(theta < 0.0, theta, -np.inf).max(axis=-1)
    return (ahead - behind < np.pi) | (np.abs(theta) <= 1e-12).any(axis=-1)


def ring_equilibrium(
    ball_angle_rad,
    bearing: Bearing,
    radial_load_n,
    clearance_m,
    omega_rad_s,
    raceway,
    *,
    centrifugal=True,
    gravity=False,
    rtol=SOLVER_RTOL,
    initial_shift_xy_m=None,
    unit_xy=None,
    load_xy_n=None,
    cage="none",
) -> RingSolution:
    """Checked inputs to :func:`signatelec.physics.ring_equilibrium.solve_ring`, checked output.

    ``raceway`` is ``((c_inner, c_outer), exponent)`` (:func:`raceway_law`, or a scene's law);
    the other parameters are those of :func:`solve_equilibrium_over_time`, and ``cage`` that of
    :func:`ball_body_force_n`; ``rtol`` the residual
    asked, relative to the load carried; ``unit_xy`` the ``(sin psi, -cos psi)`` arrays when the
    caller has them; ``clearance_m`` may be a (T, Z) array (each ball's at each instant) and
    ``load_xy_n`` a (T, 2) array of the load at each instant, replacing the static F_r's (a
    rotating or time-varying load); ``initial_shift_xy_m`` may be (T, 2), each instant's own
    start (:func:`~signatelec.physics.ring_equilibrium.solve_ring`). Raises as
    :func:`solve_equilibrium_over_time`.
    """
    from signatelec.physics.ring_equilibrium import solve_ring

    psi = np.asarray(ball_angle_rad, dtype=float)
    if psi.ndim != 2 or psi.shape[1] < 3:
        raise ValueError(f"ball_angle_rad: shape (T, Z) with Z >= 3 expected, got {psi.shape}")
    if not np.isfinite(radial_load_n) or radial_load_n < 0.0:
        raise ValueError(f"radial_load_n = {radial_load_n!r}: must be a finite number >= 0")
    load_xy = ring_load_xy_n(bearing, radial_load_n, gravity)
    if load_xy_n is not None:
        load_xy = np.broadcast_to(np.asarray(load_xy_n, dtype=float), (psi.shape[0], 2))
    body = ball_body_force_n(psi, bearing, omega_rad_s, centrifugal, gravity, cage)
    ux, uy = (np.sin(psi), -np.cos(psi)) if unit_xy is None else unit_xy
    start = (0.0, 0.0) if initial_shift_xy_m is None else initial_shift_xy_m
    solution = solve_ring(ux, uy, body, clearance_m, load_xy, *raceway, rtol=rtol, start_xy_m=start)
    bad = np.flatnonzero(~solution.converged)
    if bad.size:
        # Why an instant failed: balls that cannot carry the load, or an ill-conditioned set.
        first = load_xy if load_xy.ndim == 1 else load_xy[bad[0]]
        carries = _ball_set_carries(psi, first) if first.any() else np.ones(len(psi), bool)
        if not carries.all():
            cannot = np.flatnonzero(~carries)
            raise ValueError(
                f"ball_angle_rad: at {cannot.size} of {psi.shape[0]} instants (first: "
                f"{cannot[0]}) the balls lie on one side, away from the load, and cannot carry it"
            )
        u = radial_unit_vectors(psi[bad[0]])
        residual = solution.inner_force_n[bad[0]] @ u - first
        raise RuntimeError(
            f"ring equilibrium not reached at {bad.size} of {psi.shape[0]} instants "
            f"(first: {int(bad[0])}; residual {float(np.hypot(*residual)):.3g} N for a load of "
            f"{float(np.hypot(*first)):.6g} N)"
        )
    return solution


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
    and for arbitrary ball angles), by the damped Newton of
    :mod:`signatelec.physics.ring_equilibrium` to a residual of ``SOLVER_RTOL`` (1e-12) of the
    load carried. Instants are solved in turn, each started from the extrapolation of the ones
    before (the first from ``initial_shift_xy_m``, or a shift squeezing the two balls nearest the
    load), so a large clearance (few balls loaded) is handled and a time series is cheap.

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
    solution = ring_equilibrium(
        ball_angle_rad,
        bearing,
        radial_load_n,
        clearance_m,
        omega_rad_s,
        raceway_law(bearing, law, linear_stiffness_n_m),
        centrifugal=centrifugal,
        gravity=gravity,
        initial_shift_xy_m=initial_shift_xy_m,
    )
    shift, inner = solution.shift_xy_m, solution.inner_force_n
    delta_r = np.hypot(shift[..., 0], shift[..., 1])
    return QuasiStaticState(
        shift_xy_m=shift,
        delta_r_m=delta_r,
        epsilon=epsilon_from_shift(delta_r, clearance_m),
        load_zone_limit_rad=load_zone_limit_rad(delta_r, clearance_m),
        inner_force_n=inner,
        outer_force_n=solution.outer_force_n,
        loaded_count=np.count_nonzero(inner > 0.0, axis=-1),
    )


def solve_equilibrium(
    ball_angle_rad, bearing: Bearing, radial_load_n, clearance_m, omega_rad_s, **options
) -> QuasiStaticState:
    """Quasi-static equilibrium of the inner ring for one ball set of shape (Z,).

    ``options`` and the rest are those of :func:`solve_equilibrium_over_time`, which gives the
    equations, the method and the special cases (F_r = 0 with a clearance returns the centred,
    indeterminate solution s = 0).
    """
    psi = np.asarray(ball_angle_rad, dtype=float)
    if psi.ndim != 1:
        raise ValueError(f"ball_angle_rad: shape (Z,) expected, got {psi.shape}")
    state = solve_equilibrium_over_time(
        psi[None, :], bearing, radial_load_n, clearance_m, omega_rad_s, **options
    )
    return QuasiStaticState(**{k: v[0] for k, v in vars(state).items()})


def clearance_for_epsilon(
    bearing, radial_load_n: float, omega_rad_s: float, epsilon: float
) -> float:
    """Radial clearance (m; < 0 a preload) giving load parameter ``epsilon`` (seed eq. 15).

    Quasi-static Hertz equilibrium with the centrifugal force and gravity, averaged over the ball
    positions of one ball spacing; epsilon falls monotonically as the clearance grows, so a
    bracketing root finder is safe. 0 < epsilon < 0.5: a clearance up to 5 % of the ball radius
    (the largest a scene accepts); 0.5: none; above 0.5: a preload down to
    :func:`preload_limit_m` (ISO 76). For the seed's 6208 at 5820 N and 500 rad/s, epsilon =
    0.3 needs about +47 um. Raises ValueError, naming epsilon and F_r, when no clearance in that
    span gives ``epsilon``.
    """
    from scipy.optimize import brentq

    if not (math.isfinite(epsilon) and epsilon > 0.0):
        raise ValueError(f"epsilon = {epsilon!r}: must be a finite number > 0")
    if epsilon == 0.5:
        return 0.0
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

    if epsilon < 0.5:
        upper = 0.05 * bearing.ball_radius_m  # the largest clearance a scene accepts
        try:
            return float(brentq(excess, 1e-9, upper, xtol=1e-10))
        except ValueError as exc:
            raise ValueError(
                f"epsilon = {epsilon:g}: no clearance up to 5 % of the ball radius gives it at "
                f"F_r = {radial_load_n:g} N ({exc})"
            ) from None
    lowest = -preload_limit_m(bearing)
    reached = excess(lowest) + epsilon
    if reached < epsilon:
        raise ValueError(
            f"epsilon = {epsilon:g}: beyond the largest preload ({lowest:.3g} m, 4.2 GPa) at "
            f"F_r = {radial_load_n:g} N, which gives {reached:.3g}"
        )
    return float(brentq(excess, lowest, 0.0, xtol=1e-10))


#: Maximum Hertz contact pressure a ball bearing takes statically (ISO 76), Pa.
STATIC_PRESSURE_LIMIT_PA = 4.2e9


def preload_limit_m(bearing) -> float:
    """Largest preload (-clearance) whose ball load keeps p0 = 3 Q / (2 pi a b) <= 4.2 GPa.

    The contact ellipse is Hamrock-Brewe's (seed eqs 17-18); the load from the Hertz law
    (eq. 8) with inner and outer contacts in series.
    """
    from signatelec.physics.conductance import contact_ellipse

    (ci, co), _ = raceway_law(bearing, "hertz")
    radii = raceway_radii(bearing)
    e_eq = bearing.ball_material.plane_strain_modulus_pa
    q_ref = 1000.0
    q_limit = math.inf
    for race in ("inner", "outer"):
        _, _, r_eq, alpha = radii[race]
        _, _, area = contact_ellipse(q_ref, r_eq, alpha, e_eq)
        p0 = 1.5 * q_ref / area
        q_limit = min(q_limit, q_ref * (STATIC_PRESSURE_LIMIT_PA / p0) ** 3)  # p0 ~ Q^(1/3)
    return float(hertz_overlap(q_limit, ci) + hertz_overlap(q_limit, co))
