"""The contact law a scene asks for, shared by the DEM and the quasi-static engines.

A scene names a law (Hertz, Harris or linear); this module turns it into the normal-law
coefficients of each contact type with the reference forces at which the linear law matches
Hertz (Stribeck's load on ball/raceway contacts, the spin-up chain force on cage contacts).
"""

from __future__ import annotations

import math

from signatelec.config.bearing import INNER, OUTER
from signatelec.physics.contact import law_coefficients


def stribeck_load_n(scene) -> float:
    """Stribeck's maximum ball load 4.37 F_r / Z (at least 10 N), N."""
    return max(4.37 * scene.operating.radial_load_n / scene.bearing.n_balls, 10.0)


def chain_force_n(scene) -> float:
    """Force the cage-ball chain passes to drive the unloaded balls through the spin-up, N.

    ``ceil(Z/2) (m_b + I_b/R_b^2) a_t`` with a_t = r_p omega_c pi / (2 T_spin), the peak orbital
    acceleration of the sinusoidal spin-up; for a spin-up step, what friction can pass to a ball,
    mu times Stribeck's load.
    """
    b = scene.bearing
    t_spin = scene.procedure.spin_up_time_s if scene.procedure.spin_up else 0.0
    if t_spin <= 0.0:
        return max(b.friction_coefficient, 0.05) * stribeck_load_n(scene)
    omega_c = b.cage_speed_rad_s(scene.operating.omega_rad_s)
    a_t = b.pitch_radius_m * omega_c * math.pi / (2.0 * t_spin)
    inertia_mass = b.ball_mass_kg + b.ball_inertia_kg_m2 / b.ball_radius_m**2
    return max(math.ceil(b.n_balls / 2) * inertia_mass * a_t, 1.0)


def linear_reference_forces_n(scene) -> list[float]:
    """Force at which each contact type's linear law matches Hertz (contact.law_coefficients):
    Stribeck's load on ball/raceway and ball/ball contacts, the chain force on cage contacts
    (cage balls and the rigid cage's pockets)."""
    q, chain = stribeck_load_n(scene), chain_force_n(scene)
    return [q, q, chain, chain, q, chain]


def scene_law(scene):
    """Normal-law coefficients (6,) and exponent of a scene (see contact.law_coefficients)."""
    stiffness = scene.numerics.linear_stiffness_n_m or None
    return law_coefficients(
        scene.bearing, scene.effects.contact_law, stiffness, linear_reference_forces_n(scene)
    )


def preload_ball_force_n(coefficients, exponent: float, clearance_m: float) -> float:
    """Force on each ball when the outer race closes by -clearance_m (inner/outer in series)."""
    if clearance_m >= 0.0:
        return 0.0
    compliance = coefficients[INNER] ** (-1.0 / exponent) + coefficients[OUTER] ** (-1.0 / exponent)
    return (-clearance_m / compliance) ** exponent
