"""Harris' load distribution of a radially loaded ball bearing: closed forms and integrals.

The many-ball theory the quasi-static equilibrium (:mod:`signatelec.physics.quasistatic`) and the
DEM are checked against: the radial integral J_r(epsilon), the maximum ball load (Stribeck at
zero clearance), the load parameter epsilon of seed eq. 15 and the load-zone half angle.
Conventions (shift, clearance, angles) are those of :mod:`signatelec.physics.quasistatic`.

References
----------
Seed: C. Machado, M. Guessasma, E. Bellenger, *Modelling of ball bearing loading by DEM for
electromechanical coupling*; eq. 14 (clearance), eq. 15 (load parameter), section 2.2.2.
T. A. Harris, *Rolling Bearing Analysis*, 4th ed., Wiley, 2001: section 7.3 and table 7.1
(radially loaded bearings, the radial integral J_r(epsilon)).
"""

from __future__ import annotations

import math

import numpy as np


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
    from scipy.integrate import quad  # here: a scene's validation needs none of scipy

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
