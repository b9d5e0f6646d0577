"""Critical time step of a scene from its stiffest contacts and lightest bodies.

For each body (ball translation and spin, cage ball, inner ring) the contacts it can carry are
summed as springs at their tangent stiffness under a conservative force scale, giving a natural
frequency omega and a damping ratio zeta. An explicit central-difference (Verlet) step of a
damped oscillator is stable for ``dt < 2 (sqrt(1 + zeta^2) - zeta) / omega``; the scene's limit
is the smallest over bodies.

Force scale: ``F_s = 2 (F_r + Q_preload) + F_c`` (a sudden load may overshoot to twice its static
value; one ball may carry F_r when the clearance leaves a single ball loaded) plus 1 N. Cage
contacts only carry what friction can pass to the balls, so they take ``max(mu, 0.05) F_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from signatelec.bearing import BALL_BALL, BALL_CAGE, CAGE_WALL, INNER, OUTER, contact_properties
from signatelec.contact import law_coefficients, mindlin_coefficient


@dataclass(frozen=True)
class StabilityLimit:
    dt_limit_s: float
    body: str
    omega_rad_s: float
    damping_ratio: float
    force_scale_n: float

    def describe(self) -> str:
        return (
            f"stability limit {self.dt_limit_s:.3g} s set by the {self.body} "
            f"(omega = {self.omega_rad_s:.3g} rad/s, damping ratio {self.damping_ratio:.2f}, "
            f"force scale {self.force_scale_n:.4g} N)"
        )


def linear_reference_force_n(scene) -> float:
    """Force at which the linear law matches Hertz: Stribeck's maximum ball load 4.37 F_r / Z."""
    return max(4.37 * scene.operating.radial_load_n / scene.bearing.n_balls, 10.0)


def scene_law(scene):
    """Normal-law coefficients (5,) and exponent of a scene (see contact.law_coefficients)."""
    stiffness = scene.numerics.linear_stiffness_n_m or None
    return law_coefficients(
        scene.bearing, scene.effects.contact_law, stiffness, linear_reference_force_n(scene)
    )


def preload_ball_force_n(coefficients, exponent: float, clearance_m: float) -> float:
    """Force on each ball when the outer race closes by -clearance_m (inner/outer in series)."""
    if clearance_m >= 0.0:
        return 0.0
    compliance = coefficients[INNER] ** (-1.0 / exponent) + coefficients[OUTER] ** (-1.0 / exponent)
    return (-clearance_m / compliance) ** exponent


def _tangent(coef: float, exponent: float, force_n: float) -> float:
    if exponent == 1.0:
        return coef
    return exponent * coef ** (1.0 / exponent) * force_n ** ((exponent - 1.0) / exponent)


def _damped_limit(stiffness: float, mass: float, zeta: float) -> tuple[float, float]:
    omega = math.sqrt(stiffness / mass)
    return 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta) / omega, omega


def stability_limit(scene) -> StabilityLimit:
    b = scene.bearing
    e = scene.effects
    coef, n = scene_law(scene)
    props = contact_properties(b)
    mb, mc = b.ball_mass_kg, b.cage_ball_mass_kg
    fc = mb * b.cage_speed_rad_s(scene.operating.omega_rad_s) ** 2 * b.pitch_radius_m
    q_pre = preload_ball_force_n(coef, n, scene.operating.clearance_m)
    fs = 2.0 * (scene.operating.radial_load_n + q_pre) + fc + 1.0
    f_cage = max(b.friction_coefficient, 0.05) * fs
    k = [_tangent(coef[i], n, fs if i in (INNER, OUTER, BALL_BALL) else f_cage) for i in range(5)]
    damp = 1.0 if e.damping else 0.0

    candidates = []

    def body(name: str, springs: list[tuple[float, float]], mass: float) -> None:
        """springs: (stiffness, reduced mass of that contact) pairs acting on one body."""
        ktot = sum(s for s, _ in springs)
        ctot = damp * sum(2.0 * math.sqrt(s * m) for s, m in springs)
        zeta = ctot / (2.0 * math.sqrt(ktot * mass))
        dt, omega = _damped_limit(ktot, mass, zeta)
        candidates.append(StabilityLimit(dt, name, omega, zeta, fs))

    neighbours = (
        [(k[BALL_CAGE], props[BALL_CAGE].reduced_mass_kg)] * 2
        if e.cage
        else [(k[BALL_BALL], props[BALL_BALL].reduced_mass_kg)] * 2
    )
    race = [(k[INNER], mb), (k[OUTER], mb)]
    friction = e.friction and b.friction_coefficient > 0.0
    if friction:
        # Mindlin stiffness eq. 7 at the same force (linear law: K_t = 2/3 K_n, eq. 5)
        kt = []
        for i in (INNER, OUTER):
            p = props[i]
            if n == 1.0:
                kt.append(2.0 / 3.0 * coef[i])
            else:
                kt.append(
                    mindlin_coefficient(p.radius_eq_m, p.shear_modulus_pa, p.poisson)
                    * fs ** (1.0 / 3.0)
                )
        body("ball (translation)", race + neighbours + [(kt[0], mb), (kt[1], mb)], mb)
        inertia_mass = b.ball_inertia_kg_m2 / b.ball_radius_m**2  # 0.4 m
        if e.tangential == "spring":
            body("ball (spin)", [(kt[0], mb), (kt[1], mb)], inertia_mass)
        else:
            # seed law: F_t = -(K_t dt + C_t) v_t, a pure damper; explicit stability needs
            # dt * sum(K_t dt + C_t) < 2 I / R^2
            ct = damp * sum(2.0 * math.sqrt(s * mb) for s in kt)
            ks = sum(kt)
            dt = (-ct + math.sqrt(ct * ct + 8.0 * ks * inertia_mass)) / (2.0 * ks)
            candidates.append(
                StabilityLimit(
                    dt, "ball (spin, seed tangential law)", math.sqrt(ks / inertia_mass), 0.0, fs
                )
            )
    else:
        body("ball (translation)", race + neighbours, mb)
    if e.cage:
        props_bc, props_w = props[BALL_CAGE], props[CAGE_WALL]
        body(
            "cage ball",
            [(k[BALL_CAGE], props_bc.reduced_mass_kg)] * 2
            + [(k[CAGE_WALL], props_w.reduced_mass_kg)],
            mc,
        )
    n_inner = max(2, b.n_balls // 2 + 1)
    body("inner ring", [(k[INNER], mb)] * n_inner, b.inner_ring_mass_kg)
    return min(candidates, key=lambda c: c.dt_limit_s)


#: Maximum Hertz contact pressure a ball bearing takes statically (ISO 76), Pa.
STATIC_PRESSURE_LIMIT_PA = 4.2e9


def preload_limit_m(bearing) -> float:
    """Largest preload (-clearance) whose ball load keeps p0 = 3 Q / (2 pi a b) <= 4.2 GPa.

    The contact ellipse is Hamrock-Brewe's (seed eqs 17-18); the load from the Hertz law
    (eq. 8) with inner and outer contacts in series.
    """
    from signatelec.bearing import raceway_radii
    from signatelec.electrical import contact_ellipse

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
