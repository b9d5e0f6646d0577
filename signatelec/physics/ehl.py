"""Elastohydrodynamic film of a ball/raceway contact: viscosity, entrainment speed, film thickness.

The seed's contacts are dry; its conclusion plans "the effect of lubricant with the theory of
elastohydrodynamic lubrication". This module gives, per contact and instant:

- the oil's dynamic viscosity at the operating temperature: ASTM D341 (Walther) through the
  kinematic viscosities at 40 and 100 C, times the density at that temperature;
- the entrainment (mean rolling) speed of each ball/raceway contact from the simulated ball
  orbit and spin and the ring speed (not only the nominal kinematics);
- Hamrock and Dowson's central and minimum film thickness of an elliptical contact, with the
  ellipticity k = alpha^(2/pi) of seed eq. 17 and the radii R_x, R_y of seed eqs 12-13;
- the film parameter Lambda = h_min / sigma and the lubrication regime.

References
----------
B. J. Hamrock, D. Dowson, *Isothermal elastohydrodynamic lubrication of point contacts, Part III:
fully flooded results*, ASME J. Lubr. Technol. 99 (1977) 264-276 (eqs for H_c and H_min).
B. J. Hamrock, D. Dowson, *Ball Bearing Lubrication*, Wiley, 1981, ch. 8 and 11 (regimes by Lambda).
B. J. Hamrock, *Fundamentals of Fluid Film Lubrication*, McGraw-Hill 1994 (NASA RP-1255, 1991),
ch. 22 (rolling-element bearings: u = (d_e^2 - d^2) |omega_i - omega_o| / (4 d_e)).
ASTM D341, *Viscosity-temperature charts for liquid petroleum products* (Walther's equation).
T. E. Tallian, *On competing failure modes in rolling contact*, ASLE Trans. 10 (1967) 418-439
(Lambda < 1 boundary, 1-3 mixed, > 3 full film).
"""

from __future__ import annotations

import math

import numpy as np

#: Lambda below which a contact is in boundary lubrication, and above which in full film
#: (Tallian 1967; Hamrock and Dowson 1981, ch. 11): between them the film is mixed.
BOUNDARY_LAMBDA = 1.0
FULL_FILM_LAMBDA = 3.0
LUBRICATION_REGIMES = ("boundary", "mixed", "full")

_KELVIN = 273.15
_WALTHER_SHIFT_MM2_S = 0.7  # ASTM D341, for kinematic viscosities above 2 mm^2/s


def walther_kinematic_viscosity_mm2_s(temperature_c, nu_40c_mm2_s, nu_100c_mm2_s):
    """Kinematic viscosity (mm^2/s) at ``temperature_c`` by ASTM D341 (Walther):

    log10 log10(nu + 0.7) = A - B log10(T), with A and B through the 40 and 100 C values.
    """
    t1, t2 = math.log10(40.0 + _KELVIN), math.log10(100.0 + _KELVIN)
    w1 = math.log10(math.log10(nu_40c_mm2_s + _WALTHER_SHIFT_MM2_S))
    w2 = math.log10(math.log10(nu_100c_mm2_s + _WALTHER_SHIFT_MM2_S))
    b = (w1 - w2) / (t2 - t1)
    a = w1 + b * t1
    w = a - b * np.log10(np.asarray(temperature_c, dtype=float) + _KELVIN)
    return 10.0 ** (10.0**w) - _WALTHER_SHIFT_MM2_S


def entrainment_speed_m_s(
    orbit_rad_s, spin_rad_s, inner_omega_rad_s, ball_radius_m, inner_race_m, outer_race_m
):
    """Entrainment (mean rolling) speed of the inner and outer contact of each ball, m/s.

    In the frame of a contact point (it orbits with the ball centre at ``orbit_rad_s``), the ball
    surface moves at R_b (omega_c - omega_b) at the inner contact and R_b (omega_b - omega_c) at
    the outer one (``spin_rad_s`` = omega_b, lab frame, negative when the ball rolls), the inner
    race at (omega_i - omega_c) R_inn and the fixed outer race at -omega_c R_out. The entrainment
    speed is the magnitude of their mean. In pure rolling both equal omega_c R_out = Hamrock's
    u = (d_e^2 - d^2) omega_i / (4 d_e).

    Returns ``(inner_m_s, outer_m_s)``, arrays of the broadcast shape.
    """
    wc = np.asarray(orbit_rad_s, dtype=float)
    wb = np.asarray(spin_rad_s, dtype=float)
    wi = np.asarray(inner_omega_rad_s, dtype=float)
    inner = 0.5 * np.abs(ball_radius_m * (wc - wb) + (wi - wc) * inner_race_m)
    outer = 0.5 * np.abs(ball_radius_m * (wb - wc) - wc * outer_race_m)
    return inner, outer


def ellipticity(radius_ratio):
    """k = alpha^(2/pi), seed eq. 17 (Hamrock-Brewe), alpha = R_y / R_x >= 1."""
    alpha = np.asarray(radius_ratio, dtype=float)
    return np.where(alpha >= 1.0, alpha, 1.0 / alpha) ** (2.0 / math.pi)


def film_thickness_m(
    load_n,
    speed_m_s,
    viscosity_pa_s,
    pressure_viscosity_1_pa,
    radius_x_m,
    radius_ratio,
    plane_modulus_pa,
):
    """Hamrock-Dowson (1977) central and minimum film thickness of an elliptical contact, m.

    .. math::

        H_c = h_c / R_x = 2.69 U^{0.67} G^{0.53} W^{-0.067} (1 - 0.61 e^{-0.73 k}),
        H_{min} = 3.63 U^{0.68} G^{0.49} W^{-0.073} (1 - e^{-0.68 k}),

    U = eta_0 u / (E' R_x), G = alpha_p E', W = Q / (E' R_x^2), k = (R_y / R_x)^(2/pi). E' is the
    seed's E_eq = E / (1 - nu^2) (two bodies of one steel). A load <= 0 gives NaN (no EHL contact).

    Returns ``(h_central_m, h_min_m)``.
    """
    q = np.asarray(load_n, dtype=float)
    u = np.asarray(speed_m_s, dtype=float)
    k = ellipticity(radius_ratio)
    e, rx = plane_modulus_pa, radius_x_m
    with np.errstate(divide="ignore", invalid="ignore"):
        speed = viscosity_pa_s * u / (e * rx)
        material = pressure_viscosity_1_pa * e
        load = np.where(q > 0.0, q, np.nan) / (e * rx * rx)
        central = (
            2.69 * speed**0.67 * material**0.53 * load**-0.067 * (1 - 0.61 * np.exp(-0.73 * k))
        )
        minimum = 3.63 * speed**0.68 * material**0.49 * load**-0.073 * (1 - np.exp(-0.68 * k))
    return central * rx, minimum * rx


def composite_roughness_m(ball_rq_m: float, race_rq_m: float) -> float:
    """sigma = sqrt(Rq_ball^2 + Rq_race^2), the composite rms roughness of Lambda."""
    return math.hypot(ball_rq_m, race_rq_m)


def lubrication_regime(film_parameter):
    """Index into :data:`LUBRICATION_REGIMES` of each Lambda: 0 boundary, 1 mixed, 2 full film."""
    lam = np.asarray(film_parameter, dtype=float)
    return (lam >= BOUNDARY_LAMBDA).astype(np.int8) + (lam > FULL_FILM_LAMBDA)
