"""Conductance of a steel ball between its contact ellipses (seed section 3, eqs 16-18).

Hertz contact ellipses in the Hamrock-Brewe approximation (eqs 17-18) from the normal forces,
and the conductance of a homogeneous ball between two of its contact surfaces (eq. 16). The
network these conductances form is solved by :mod:`signatelec.physics.electrical`.

References
----------
Seed: C. Machado, M. Guessasma, E. Bellenger, *Modelling of ball bearing loading by DEM for
electromechanical coupling*, section 3, eqs 16-18.
B. J. Hamrock, D. E. Brewe, *Simplified solution for stresses and deformations*, ASME J. Lubr.
Technol. 105 (1983) 171-177; B. J. Hamrock, W. J. Anderson, *Rolling-element bearings*, NASA
RP-1105 (1983) (seed ref. 11).
T. A. Harris, *Rolling Bearing Analysis*, 4th ed., Wiley, 2001, chapter 6 (exact Hertz ellipse).
"""

from __future__ import annotations

import math

import numpy as np

from signatelec.config.bearing import Bearing, raceway_radii

_Q = math.pi / 2.0 - 1.0  # Hamrock-Brewe's q, seed after eq. 17


# --- contact ellipses (eqs 17-18) -----------------------------------------------------------------


def contact_ellipse(normal_force_n, radius_eq_m, radius_ratio, plane_modulus_pa):
    """Semi-axes and area of a Hertz contact ellipse, Hamrock-Brewe approximation.

    Seed eqs 17-18:

    .. math::

        k = \\alpha^{2/\\pi}, \\quad \\chi = 1 + \\frac{\\pi/2 - 1}{\\alpha}, \\quad
        a = \\left(\\frac{6 \\chi F R_{eq}}{\\pi k E_{eq}}\\right)^{1/3}, \\quad
        b = \\left(\\frac{6 k^2 \\chi F R_{eq}}{\\pi E_{eq}}\\right)^{1/3}, \\quad S = \\pi a b.

    Parameters
    ----------
    normal_force_n : array_like
        Normal contact force F (N). Zero or negative means no contact: a, b and S are 0.
    radius_eq_m : array_like
        R_eq = 1 / (curvature sum) (m): ``raceway_radii(bearing)[race][2]`` for a raceway (seed
        eqs 12-13), ``R_b / 4`` for two equal balls.
    radius_ratio : array_like
        alpha = r2 / r1 (seed eqs 12-13); 1 for two balls. A ratio below 1 is read as 1 / alpha with
        the two axes exchanged (Hamrock-Brewe's fits assume alpha >= 1).
    plane_modulus_pa : array_like
        E_eq = E / (1 - nu^2) (Pa), ``bearing.ball_material.plane_strain_modulus_pa``; for two
        bodies of one material it is Hamrock-Brewe's E'.

    Returns
    -------
    a_m, b_m : ndarray
        Semi-axes along the r1 and r2 directions (m); for alpha >= 1, a <= b. The seed defines
        its ellipticity as k = b / a and Hamrock-Brewe as k = a / b with their a along the larger
        radius: both are the long over the short axis, so the letters are swapped but the number
        k, the product a b and the area are the same.
    area_m2 : ndarray
        S = pi a b (m^2).
    """
    force = np.maximum(np.asarray(normal_force_n, dtype=float), 0.0)
    ratio = np.asarray(radius_ratio, dtype=float)
    alpha = np.where(ratio >= 1.0, ratio, 1.0 / ratio)
    k = alpha ** (2.0 / math.pi)
    chi = 1.0 + _Q / alpha
    scale = 6.0 * chi * force * radius_eq_m / (math.pi * plane_modulus_pa)
    short = np.cbrt(scale / k)
    long = np.cbrt(scale * k * k)
    a_m = np.where(ratio >= 1.0, short, long)
    b_m = np.where(ratio >= 1.0, long, short)
    return a_m, b_m, math.pi * a_m * b_m


def bearing_contact_area(normal_force_n, bearing: Bearing, contact: str):
    """Contact area S (m^2) of a steel ball on ``"inner"`` / ``"outer"`` raceway or ``"ball_ball"``.

    Raceways take R_eq and alpha of seed eqs 12-13
    (:func:`signatelec.config.bearing.raceway_radii`); two
    equal balls touch with alpha = 1 and R_eq = R_b / 4 (curvature sum 4 / R_b; not the Hertz
    R* = R_b / 2 of seed table 2, which pairs with E* = E_eq / 2 rather than E_eq). Eq. 18.
    """
    if contact == "ball_ball":
        radius_eq_m, alpha = 0.25 * bearing.ball_radius_m, 1.0
    elif contact in ("inner", "outer"):
        _, _, radius_eq_m, alpha = raceway_radii(bearing)[contact]
    else:
        raise ValueError(f"contact = {contact!r}: allowed 'inner', 'outer' or 'ball_ball'")
    modulus = bearing.ball_material.plane_strain_modulus_pa
    return contact_ellipse(normal_force_n, radius_eq_m, alpha, modulus)[2]


# --- conductance of one ball (eq. 16) -------------------------------------------------------------


def ball_conductance(area_i_m2, area_j_m2, cos_theta=-1.0, *, conductivity_s_m, ball_volume_m3):
    """Conductance (S) of a homogeneous ball between two contact surfaces, seed eq. 16.

    .. math:: C_{ij} = \\frac{\\gamma S_i S_j}{2 V_b} (1 - \\cos\\theta)

    Parameters
    ----------
    area_i_m2, area_j_m2 : array_like
        Contact areas S_i, S_j (m^2); a zero area gives a zero conductance.
    cos_theta : array_like
        Cosine of the angle between the two contact points seen from the ball centre; -1
        (theta = pi) for diametrically opposite contacts, as the seed takes for inner/outer.
    conductivity_s_m : float
        gamma (S/m), ``bearing.electrical_conductivity_s_m``.
    ball_volume_m3 : float
        V_b (m^3), ``bearing.ball_volume_m3``.
    """
    cos_theta = np.clip(cos_theta, -1.0, 1.0)
    return conductivity_s_m * area_i_m2 * area_j_m2 * (1.0 - cos_theta) / (2.0 * ball_volume_m3)
