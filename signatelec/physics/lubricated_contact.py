"""Electrical model of a lubricated ball bearing: film capacitance, asperity conduction, impedance.

The seed's contacts conduct as dry metal (eqs 16-18). With an oil film each ball/raceway contact
is, in parallel:

- **the film**: a capacitor, the Hertz ellipse at the central film thickness h_c (parallel plate,
  eps S / h_c) plus the zone outside it where the gap grows with the surfaces' curvature, up to
  the inlet meniscus where the gap reaches ``meniscus_gap_m``; and the film's own leakage
  resistance rho h_c / S over the Hertz zone;
- **the asperity contacts**: metal through the fraction f(Lambda) of the Hertz area in real
  contact, Greenwood and Williamson's real area of Gaussian summits F_1(Lambda) / F_1(0), cut to
  0 at the full-film limit Lambda = 3 (:func:`metallic_fraction`): 1 at Lambda = 0, 0.21 at 1.
  The seed's dry ball conductance (eq. 16, split equally between the ball's two contacts) is
  the limit as the speed falls.

Outside-zone capacitance. Beyond the Hertz ellipse (semi-axes a along R_x, b along R_y) the gap
is taken as h_c plus the undeformed separation counted from the ellipse's edge along each ray of
elliptic coordinates x = a rho cos t, y = b rho sin t (rho >= 1): h = h_c + (rho^2 - 1) q(t),
q(t) = a^2 cos^2 t / (2 R_x) + b^2 sin^2 t / (2 R_y). The elastic displacement outside the
ellipse is left out (the true gap opens as (rho - 1)^(3/2) at the edge: this capacitance is a lower
bound near the edge). Integrating eps dA / h from the edge to the meniscus gap h_m gives the
closed form

    C_out = 2 pi eps sqrt(R_x R_y) ln(h_m / h_c),

independent of the ellipse, the classic sphere-on-flat result for R_x = R_y (tested against a
direct numerical integration of the gap in tests/test_lubrication.py). An unloaded contact has
no Hertz zone: the same expression with the separation of the ball from its race for h_c.

References
----------
J. A. Greenwood, J. B. P. Williamson, *Contact of nominally flat surfaces*, Proc. R. Soc. Lond.
A 295 (1966) 300-319 (real area ~ F_1(h / sigma) of the Gaussian summit heights).
K. Jablonka, R. Glovnea, J. Bongaerts, *Evaluation of EHD films by electrical capacitance*,
J. Phys. D: Appl. Phys. 45 (2012) 385301; *Quantitative measurements of film thickness in a
radially loaded deep-groove ball bearing*, Tribol. Int. 119 (2018) 239-249 (the Hertz zone and
the outside zone; the outside zone dominates).
T. Schirra, G. Martin, S. Puchtler, E. Kirchner, *Electric impedance of rolling bearings:
consideration of unloaded rolling elements*, Tribol. Int. 158 (2021) 106927; Y. Gemeinder et al.,
bearing impedance model for ball bearings, ICEM 2016 (the bearing as a network of contact
impedances). M. Manjunath, S. Hausner, A. Heine, P. De Baets, D. Fauconnier, *Electrical
impedance spectroscopy for precise film thickness assessment in line contacts*, Lubricants 12(2)
(2024) 51: on a cylindrical roller thrust bearing the measured EHL capacitance is 3 to 11 times
the Hertz-zone value.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erfc

from signatelec.physics.conductance import ball_conductance
from signatelec.physics.ehl import FULL_FILM_LAMBDA

#: Vacuum permittivity, F/m (CODATA 2018).
EPSILON_0_F_M = 8.8541878128e-12
_F1_AT_ZERO = 1.0 / math.sqrt(2.0 * math.pi)


def _f1(lam):
    """Greenwood-Williamson's F_1(h) = integral_h^inf (s - h) phi(s) ds = phi(h) - h Q(h)."""
    return np.exp(-0.5 * lam * lam) * _F1_AT_ZERO - lam * 0.5 * erfc(lam / math.sqrt(2.0))


def metallic_fraction(film_parameter):
    """Share of the Hertz area in asperity contact at a film parameter Lambda.

    Greenwood and Williamson's real area of Gaussian summits, F_1(Lambda), normalised to 1 at
    Lambda = 0 and cut to 0 at the full-film limit Lambda = 3 (:data:`FULL_FILM_LAMBDA`):
    (F_1(Lambda) - F_1(3)) / (F_1(0) - F_1(3)). Finished bearing surfaces have fewer high peaks
    than a Gaussian (negative skewness), and a full film carries no metallic contact; without
    the cut the Gaussian tail (F_1(3) / F_1(0) = 1e-3) would keep a few ohms of metal beside a
    film of 100 kilohms. 1 at Lambda = 0 (the seed's dry contact), 0.208 at 1, 0 from 3.
    """
    lam = np.maximum(np.asarray(film_parameter, dtype=float), 0.0)
    top = _f1(FULL_FILM_LAMBDA)
    return np.clip((_f1(lam) - top) / (_F1_AT_ZERO - top), 0.0, 1.0)


def hertz_zone_capacitance_f(area_m2, gap_m, relative_permittivity: float):
    """Parallel-plate capacitance eps_0 eps_r S / h of the Hertz ellipse, F."""
    return EPSILON_0_F_M * relative_permittivity * np.asarray(area_m2) / np.asarray(gap_m)


def outside_capacitance_f(radius_x_m, radius_y_m, gap_m, meniscus_gap_m, relative_permittivity):
    """Capacitance of the film outside the Hertz zone up to the meniscus, F (module docstring):

    2 pi eps_0 eps_r sqrt(R_x R_y) ln(h_m / h), 0 where the gap h reaches the meniscus gap h_m.
    """
    ratio = np.maximum(meniscus_gap_m / np.asarray(gap_m, dtype=float), 1.0)
    scale = 2.0 * math.pi * EPSILON_0_F_M * relative_permittivity
    return scale * np.sqrt(radius_x_m * radius_y_m) * np.log(ratio)


def contact_film(area_m2, gap_m, metal_fraction, radius_x_m, radius_y_m, oil):
    """Film capacitance (F) and leakage conductance (S) of contacts.

    ``area_m2``: Hertz area (0 for an unloaded contact), ``gap_m``: central film (or separation),
    ``metal_fraction``: share of the Hertz area in asperity contact (no film there), ``oil``: an
    object with ``relative_permittivity``, ``resistivity_ohm_m`` and ``meniscus_gap_m``.
    """
    film_area = (1.0 - metal_fraction) * area_m2
    eps_r = oil.relative_permittivity
    capacitance = hertz_zone_capacitance_f(film_area, gap_m, eps_r) + outside_capacitance_f(
        radius_x_m, radius_y_m, gap_m, oil.meniscus_gap_m, eps_r
    )
    leakage = film_area / (oil.resistivity_ohm_m * gap_m)
    return capacitance, leakage


def ball_impedance_ohm(
    frequency_hz,
    inner_capacitance_f,
    outer_capacitance_f,
    inner_leakage_s,
    outer_leakage_s,
    dry_conductance_s,
    inner_metal_fraction,
    outer_metal_fraction,
):
    """Complex impedance of each ball between the rings: its two contacts in series, ohm.

    Each contact is its film (capacitance and leakage) in parallel with its asperity metal, whose
    resistance is half the seed's dry ball resistance 1 / C_ij (eq. 16) over the metallic
    fraction: R_dry / (2 f). With f = 1 at both contacts and no film the ball's resistance is the
    seed's. ``frequency_hz`` broadcasts against the contact arrays (0: DC).
    """
    omega = 2.0 * np.pi * np.asarray(frequency_hz, dtype=float)
    half = 2.0 * np.asarray(dry_conductance_s, dtype=float)  # 1 / (R_dry / 2)

    def contact(capacitance, leakage, fraction):
        admittance = leakage + half * fraction + 1j * omega * capacitance
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(admittance != 0.0, 1.0 / admittance, np.inf)

    return contact(inner_capacitance_f, inner_leakage_s, inner_metal_fraction) + contact(
        outer_capacitance_f, outer_leakage_s, outer_metal_fraction
    )


def bearing_impedance_ohm(ball_impedance):
    """Balls in parallel between the rings (no ball/ball path), over the last axis, ohm."""
    with np.errstate(divide="ignore", invalid="ignore"):
        admittance = np.where(np.isfinite(ball_impedance), 1.0 / ball_impedance, 0.0).sum(axis=-1)
        return np.where(admittance != 0.0, 1.0 / admittance, np.inf)


def dry_ball_conductance_s(inner_area_m2, outer_area_m2, cos_theta, bearing) -> np.ndarray:
    """The seed's eq. 16 between a ball's inner and outer contact (0 if either is open), S."""
    return ball_conductance(
        inner_area_m2,
        outer_area_m2,
        cos_theta,
        conductivity_s_m=bearing.electrical_conductivity_s_m,
        ball_volume_m3=bearing.ball_volume_m3,
    )
