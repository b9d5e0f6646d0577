"""Contact laws of the seed (eqs 3-13) as pure functions.

Each function takes floats or numpy arrays in SI units and has no branch on its inputs, so the
same source runs in plain Python (the tests) and inside the numba kernels
(``signatelec.engines.dem``
compiles these very functions). Overlaps are positive when bodies interpenetrate (the seed writes
delta_n < 0 for contact; we use its magnitude). Closing speeds are positive when the bodies
approach.

References
----------
Seed: C. Machado, M. Guessasma, E. Bellenger, *Modelling of ball bearing loading by DEM for
electromechanical coupling*. Equation numbers below are the seed's.
T. A. Harris, *Rolling Bearing Analysis*, 4th ed., Wiley, 2001, sections 6.3-6.4 (eqs 10-11).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

# --- normal laws ---------------------------------------------------------------------------


def hertz_coefficient(radius_eq_m, shear_modulus_pa, poisson):
    """Hertz coefficient K_n^H / sqrt(delta) = 4 G sqrt(R_eq) / (3 (1 - nu)), N/m^1.5.

    Seed eqs 6 and 8: ``F_n = hertz_coefficient * delta^{3/2}``. Equal to (4/3) E* sqrt(R) with
    E* = E / (2 (1 - nu^2)) for two bodies of one material.
    """
    return 4.0 * shear_modulus_pa * np.sqrt(radius_eq_m) / (3.0 * (1.0 - poisson))


def hertz_normal_force(overlap_m, coefficient):
    """Elastic Hertz force coefficient * delta^{3/2} (seed eq. 8 without damping), N; 0 apart."""
    d = np.maximum(overlap_m, 0.0)
    return coefficient * d * np.sqrt(d)


def hertz_normal_stiffness(overlap_m, coefficient):
    """Tangent stiffness dF_n/d(delta) = 3/2 K_n^H (seed eq. 9), N/m."""
    return 1.5 * coefficient * np.sqrt(np.maximum(overlap_m, 0.0))


def hertz_overlap(force_n, coefficient):
    """Overlap carrying an elastic force, the inverse of :func:`hertz_normal_force`, m."""
    return (np.maximum(force_n, 0.0) / coefficient) ** (2.0 / 3.0)


def hertz_elastic_energy(overlap_m, coefficient):
    """Energy stored in a Hertz contact, 2/5 coefficient delta^{5/2}, J."""
    d = np.maximum(overlap_m, 0.0)
    return 0.4 * coefficient * d * d * np.sqrt(d)


def linear_normal_force(overlap_m, stiffness_n_m):
    """Elastic part of the linear law K_n delta (seed eq. 3), N; 0 apart."""
    return stiffness_n_m * np.maximum(overlap_m, 0.0)


def linear_normal_stiffness(overlap_m, stiffness_n_m):
    """Tangent stiffness of the linear law: K_n in contact, 0 apart (seed eq. 3), N/m.

    ``sign(max(delta, 0))`` is 1 in contact and 0 apart without a branch, so the function
    compiles for scalars and arrays alike.
    """
    return stiffness_n_m * np.sign(np.maximum(overlap_m, 0.0))


def linear_overlap(force_n, stiffness_n_m):
    """Overlap carrying an elastic force, the inverse of :func:`linear_normal_force`, m."""
    return np.maximum(force_n, 0.0) / stiffness_n_m


def linear_elastic_energy(overlap_m, stiffness_n_m):
    """Energy stored in a linear contact, 1/2 K_n delta^2, J."""
    d = np.maximum(overlap_m, 0.0)
    return 0.5 * stiffness_n_m * d * d


class NormalLaw(NamedTuple):
    """The elastic normal law F = c delta^n of one exponent: four functions of (x, c)."""

    force: Callable  # (overlap_m, coefficient) -> N
    stiffness: Callable  # (overlap_m, coefficient) -> dF/d(delta), N/m
    energy: Callable  # (overlap_m, coefficient) -> J
    overlap: Callable  # (force_n, coefficient) -> m, the inverse of force


#: The elastic laws by exponent (see :func:`law_coefficients`): 3/2 for Hertz and Harris
#: (eqs 6-10), 1 for the linear law (eq. 3).
NORMAL_LAWS = {
    1.5: NormalLaw(hertz_normal_force, hertz_normal_stiffness, hertz_elastic_energy, hertz_overlap),
    1.0: NormalLaw(
        linear_normal_force, linear_normal_stiffness, linear_elastic_energy, linear_overlap
    ),
}


def critical_damping(stiffness_n_m, reduced_mass_kg):
    """Critical viscous damping C = 2 sqrt(K m*) (seed eq. 5), N s/m."""
    return 2.0 * np.sqrt(np.maximum(stiffness_n_m, 0.0) * reduced_mass_kg)


def hertz_critical_damping(overlap_m, coefficient, reduced_mass_kg):
    """Critical damping (eq. 5) at the Hertz tangent stiffness (eq. 9), N s/m.

    ``critical_damping(hertz_normal_stiffness(delta, c), m)`` in closed form,
    2 sqrt(1.5 c m) delta^{1/4}: the kernel keeps the constant and the delta^{1/4} it shares
    with the tangential damping.
    """
    return (
        2.0
        * np.sqrt(1.5 * coefficient * reduced_mass_kg)
        * np.sqrt(np.sqrt(np.maximum(overlap_m, 0.0)))
    )


def damped_normal_force(elastic_force_n, damping_n_s_m, closing_speed_m_s):
    """Total normal force F_e + C v_n, clamped at zero: a contact never attracts (eq. 3, 8)."""
    return np.maximum(elastic_force_n + damping_n_s_m * closing_speed_m_s, 0.0)


# --- tangential laws ------------------------------------------------------------------------


def mindlin_coefficient(radius_eq_m, shear_modulus_pa, poisson):
    """K_t^H / |F_n|^{1/3} = 2 (3 R_eq G^2 (1 - nu))^{1/3} / (2 - nu) (seed eq. 7), N^{2/3}/m."""
    return (
        2.0 * np.cbrt(3.0 * radius_eq_m * shear_modulus_pa**2 * (1.0 - poisson)) / (2.0 - poisson)
    )


def mindlin_tangential_stiffness(normal_force_n, radius_eq_m, shear_modulus_pa, poisson):
    """No-slip Mindlin tangential stiffness K_t^H (seed eq. 7), N/m."""
    return mindlin_coefficient(radius_eq_m, shear_modulus_pa, poisson) * np.cbrt(
        np.abs(normal_force_n)
    )


def tangential_stiffness_from_overlap(overlap_m, coefficient, mindlin_coef):
    """Eq. 7 at the elastic Hertz force: K_t = mindlin_coef coefficient^{1/3} sqrt(delta).

    Using the elastic part of F_n (not the damped total) keeps K_t a function of the overlap
    alone and spares the kernel a cube root.
    """
    return mindlin_coef * np.cbrt(coefficient) * np.sqrt(np.maximum(overlap_m, 0.0))


def tangential_force(stiffness_n_m, displacement_m, damping_n_s_m, slip_speed_m_s):
    """Candidate tangential force -(K_t delta_t + C_t v_t) (seed eq. 3), opposing the slip."""
    return -(stiffness_n_m * displacement_m + damping_n_s_m * slip_speed_m_s)


def coulomb_limit(tangential_force_n, normal_force_n, friction_coefficient):
    """Clamp a candidate tangential force to the Coulomb cone |F_t| <= mu F_n (seed eq. 4)."""
    limit = friction_coefficient * np.maximum(normal_force_n, 0.0)
    return np.sign(tangential_force_n) * np.minimum(np.abs(tangential_force_n), limit)


# --- Harris law (eqs 10-11) -------------------------------------------------------------------


def raceway_curvatures(bearing, raceway: str) -> tuple[float, float]:
    """Curvature sum and curvature difference F(rho) of a ball/raceway contact (Harris 2.2), 1/m.

    Ball: rho_I = rho_II = 1/R_b. Inner race: rho_III = 1/R_inn, rho_IV = -1/R_inn^c. Outer race:
    rho_III = -1/R_out, rho_IV = -1/R_out^c.
    """
    rb = bearing.ball_radius_m
    if raceway == "inner":
        r3, r4 = 1.0 / bearing.inner_race_radius_m, -1.0 / bearing.inner_groove_radius_m
    elif raceway == "outer":
        r3, r4 = -1.0 / bearing.outer_race_radius_m, -1.0 / bearing.outer_groove_radius_m
    else:
        raise ValueError(f"raceway = {raceway!r}: allowed 'inner' or 'outer'")
    total = 2.0 / rb + r3 + r4
    difference = abs(r3 - r4) / total
    return total, difference


def harris_deformation_number(curvature_difference: float) -> float:
    """Dimensionless deformation delta* of Hertz theory for a curvature difference F(rho).

    Solves F(rho) = ((kappa^2 + 1) E(e) - 2 K(e)) / ((kappa^2 - 1) E(e)) for the ellipticity
    kappa = a/b with e^2 = 1 - 1/kappa^2, then delta* = (2 K / pi) (pi / (2 kappa^2 E))^{1/3}
    (Harris 2001, eqs 6.22-6.45; his table 6.1 tabulates the same values).
    """
    from scipy.optimize import brentq
    from scipy.special import ellipe, ellipk

    if not 0.0 <= curvature_difference < 1.0:
        raise ValueError(f"curvature_difference = {curvature_difference!r}: allowed [0, 1)")
    if curvature_difference < 1e-9:
        return 1.0

    def f_of_kappa(kappa: float) -> float:
        m = 1.0 - 1.0 / kappa**2
        big_e, big_k = ellipe(m), ellipk(m)
        return ((kappa**2 + 1.0) * big_e - 2.0 * big_k) / ((kappa**2 - 1.0) * big_e)

    kappa = brentq(lambda k: f_of_kappa(k) - curvature_difference, 1.0 + 1e-9, 1e4, xtol=1e-13)
    m = 1.0 - 1.0 / kappa**2
    return 2.0 * ellipk(m) / math.pi * (math.pi / (2.0 * kappa**2 * ellipe(m))) ** (1.0 / 3.0)


def harris_coefficient(curvature_sum_per_m: float, deformation_number: float) -> float:
    """Harris' steel-on-steel load-deflection constant K_n^r (seed eq. 10), N/m^1.5.

    Eq. 10 is written in N and mm: K = 2.15e5 (sum rho [1/mm])^{-1/2} (delta*)^{-3/2} N/mm^1.5.
    Converted here to SI (x 1000^1.5 and sum rho in 1/mm = sum rho [1/m] / 1000).
    """
    sum_rho_per_mm = curvature_sum_per_m / 1000.0
    k_n_mm = 2.15e5 * sum_rho_per_mm**-0.5 * deformation_number**-1.5
    return k_n_mm * 1000.0**1.5


# --- the law of a scene, per contact type --------------------------------------------------------

CONTACT_LAWS = ("hertz", "harris", "linear")


def law_coefficients(
    bearing,
    law: str = "hertz",
    linear_stiffness_n_m: float | None = None,
    reference_force_n=1000.0,
) -> tuple[np.ndarray, float]:
    """Normal-law coefficients of every contact type and the law's exponent.

    Returns ``(coefficients, exponent)`` with ``coefficients`` of shape (6,), indexed by the
    contact types of :mod:`signatelec.config.bearing` (INNER, OUTER, BALL_CAGE, CAGE_WALL,
    BALL_BALL, BALL_POCKET),
    such that the elastic normal force is ``coefficient * delta**exponent``.

    - ``hertz``: eq. 6/8 with the table 2 / eqs 12-13 equivalent quantities (exponent 3/2).
    - ``harris``: eq. 10 for the two steel ball/raceway contacts (Harris' constant is for steel on
      steel); the other contacts keep eq. 6 (exponent 3/2).
    - ``linear``: eq. 3 with constant stiffness (exponent 1). ``linear_stiffness_n_m`` sets the
      ball/outer-raceway stiffness; by default it is the Hertz secant stiffness F/delta at
      ``reference_force_n``. Other contact types take the Hertz secant c^{2/3} F^{1/3} at their
      own reference force, so the linear law matches Hertz at the force each contact carries;
      ``reference_force_n`` is one force for all types or six, one per contact type.
    """
    from signatelec.config.bearing import INNER, OUTER, contact_properties

    props = contact_properties(bearing)
    hertz = np.array(
        [hertz_coefficient(p.radius_eq_m, p.shear_modulus_pa, p.poisson) for p in props]
    )
    if law == "hertz":
        return hertz, 1.5
    if law == "harris":
        c = hertz.copy()
        for idx, race in ((INNER, "inner"), (OUTER, "outer")):
            total, diff = raceway_curvatures(bearing, race)
            c[idx] = harris_coefficient(total, harris_deformation_number(diff))
        return c, 1.5
    if law == "linear":
        secant = hertz ** (2.0 / 3.0) * np.asarray(reference_force_n, dtype=float) ** (1.0 / 3.0)
        if linear_stiffness_n_m is not None:
            secant = secant * (linear_stiffness_n_m / secant[OUTER])
        return secant, 1.0
    raise ValueError(f"contact_law = {law!r}: allowed {', '.join(CONTACT_LAWS)}")
