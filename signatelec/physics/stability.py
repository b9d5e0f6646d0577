"""Critical time step of a scene from its stiffest contacts and lightest bodies.

For each body (ball translation and spin, cage ball, inner ring) the contacts it can carry are
summed as springs at their tangent stiffness under a conservative force scale, giving a natural
frequency omega and a damping ratio zeta. The step of a damped oscillator x'' = -omega^2 x -
2 zeta omega x' is stable for omega dt < 2 (sqrt(1 + z^2) - z) with z = zeta for symplectic Euler
(damping at v_n) and z = 2 zeta for the kernel's velocity Verlet, whose damping takes the
predicted velocity v_n + a_n dt (von Neumann analysis of the 3x3 amplification matrix; checked in
tests/test_stability.py). The scene's limit is the smallest over bodies.

Force scales:

- ball/raceway contacts: ``F_s = 2 (F_r + Q_preload) + F_c + 1 N`` (a sudden load may overshoot
  to twice its static value; one ball may carry F_r when a clearance leaves a single ball loaded);
- cage contacts carry the chain force that drives the unloaded balls: twice
  ``ceil(Z/2) (m_b + I_b/R_b^2) a_t`` with a_t the peak orbital acceleration of the sinusoidal
  spin-up, ``r_p omega_c pi / (2 T_spin)``, but never more than friction can pass,
  ``max(mu, 0.05) F_s`` (also the value for a spin-up step).

Settings a scene may leave to ``"auto"`` (:func:`auto_spin_up_time_s`, :func:`auto_dt_s`):

- the spin-up. During the sinusoidal spin-up the cage-ball chain drives the unloaded balls with
  :func:`~signatelec.physics.laws.chain_force_n` ~ omega / T_spin. The spin-up is long enough
  when that force presses the chain's contact (ball/cage ball, or ball/ball without cage balls)
  by at most :data:`CHAIN_OVERLAP_FRACTION` of the smaller radius (Hertz, eq. 6), well below the
  kernel's 10 % abort, and, since the impacts of the balls on the cage grow with their speed,
  by a further factor ``v / SPIN_UP_SPEED_M_S`` once the pitch speed v = r_p omega_c exceeds
  that speed: T_spin ~ omega^2 above it. A radial clearance lets the unloaded balls rattle in
  their pockets: that time grows by ``1 + clearance / (CLEARANCE_SCALE_FRACTION R_b)``. Never
  shorter than the seed's 5 ms, never longer than SPIN_UP_MAX_S; the seed's 5 ms for the
  quasi-static tier, which solves the steady phase only (no set-up dynamics to keep gentle).
  Calibrated on the seed's scene (measured: 500 rad/s passes
  with 5 ms, 1000 rad/s fails with 5 and passes with 10 ms, 2000 rad/s fails with 20 and passes
  with 40 ms, 3000 rad/s fails with 40 and passes with 80 ms, a 247 um clearance at 500 rad/s
  fails with 5 and passes with 10 ms); the rule keeps a factor of about 2 over those points and
  the operating map (``signatelec study operating-map``) checks it over the catalogue. It is
  also never shorter than the ball set can follow by rolling (:func:`traction_spin_up_time_s`):
  friction at the inner contacts is all that drives the balls, so a light load (at F_r = 0 the
  ring's weight alone) asks for seconds at high speed (6208 at 351.6 rad/s: 4.3 s), where a
  shorter one leaves the balls sliding far below their rolling speed for as long;
- the time step: :data:`DT_MARGIN` times the stability limit, never above :data:`DT_ACCURACY_S`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from signatelec.config.bearing import (
    BALL_BALL,
    BALL_CAGE,
    BALL_POCKET,
    CAGE_WALL,
    INNER,
    OUTER,
    STANDARD_GRAVITY_M_S2,
    contact_properties,
)
from signatelec.physics.contact import mindlin_coefficient
from signatelec.physics.laws import chain_force_n, preload_ball_force_n, scene_law


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


def _tangent(coef: float, exponent: float, force_n: float) -> float:
    if exponent == 1.0:
        return coef
    return exponent * coef ** (1.0 / exponent) * force_n ** ((exponent - 1.0) / exponent)


def damped_step_limit(omega_rad_s: float, zeta: float, integrator: str = "verlet") -> float:
    """Largest stable step of x'' = -omega^2 x - 2 zeta omega x' for the kernel's schemes, s."""
    z = 2.0 * zeta if integrator == "verlet" else zeta
    return 2.0 * (math.sqrt(1.0 + z * z) - z) / omega_rad_s


def cage_force_scale_n(scene, force_scale_n: float) -> float:
    """Force scale of the cage contacts (see the module docstring), N."""
    cap = max(scene.bearing.friction_coefficient, 0.05) * force_scale_n
    return min(cap, 2.0 * chain_force_n(scene) + 1.0)


def stability_limit(scene) -> StabilityLimit:
    b = scene.bearing
    e = scene.effects
    coef, n = scene_law(scene)
    props = contact_properties(b)
    mb, mc = b.ball_mass_kg, b.cage_ball_mass_kg
    fc = mb * b.cage_speed_rad_s(scene.operating.omega_rad_s) ** 2 * b.pitch_radius_m
    q_pre = preload_ball_force_n(coef, n, scene.operating.clearance_m)
    # a negative load is refused by validation; its limit is never used (no complex roots)
    fs = max(2.0 * (scene.operating.radial_load_n + q_pre) + fc, 0.0) + 1.0
    f_cage = cage_force_scale_n(scene, fs)
    k = [
        _tangent(coef[i], n, fs if i in (INNER, OUTER, BALL_BALL) else f_cage)
        for i in range(len(coef))
    ]
    damp = 1.0 if e.damping == "critical" else 0.0

    candidates = []

    def body(name: str, springs: list[tuple[float, float]], mass: float) -> None:
        """springs: (stiffness, reduced mass of that contact) pairs acting on one body."""
        ktot = sum(s for s, _ in springs)
        ctot = damp * sum(2.0 * math.sqrt(s * m) for s, m in springs)
        zeta = ctot / (2.0 * math.sqrt(ktot * mass))
        omega = math.sqrt(ktot / mass)
        dt = damped_step_limit(omega, zeta, scene.numerics.integrator)
        candidates.append(StabilityLimit(dt, name, omega, zeta, fs))

    if e.cage == "balls":
        neighbours = [(k[BALL_CAGE], props[BALL_CAGE].reduced_mass_kg)] * 2
    elif e.cage == "rigid":
        neighbours = [(k[BALL_POCKET], props[BALL_POCKET].reduced_mass_kg)]  # one pocket side
    else:
        neighbours = [(k[BALL_BALL], props[BALL_BALL].reduced_mass_kg)] * 2
    race = [(k[INNER], mb), (k[OUTER], mb)]
    friction = e.friction == "coulomb" and b.friction_coefficient > 0.0
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
    if e.cage == "balls":
        props_bc, props_w = props[BALL_CAGE], props[CAGE_WALL]
        body(
            "cage ball",
            [(k[BALL_CAGE], props_bc.reduced_mass_kg)] * 2
            + [(k[CAGE_WALL], props_w.reduced_mass_kg)],
            mc,
        )
    if e.cage == "rigid":
        for name, springs, mass in rigid_cage_bodies(b, k[BALL_POCKET], props[BALL_POCKET]):
            body(name, springs, mass)
    n_inner = max(2, b.n_balls // 2 + 1)
    body("inner ring", [(k[INNER], mb)] * n_inner, b.inner_ring_mass_kg)
    return min(candidates, key=lambda c: c.dt_limit_s)


def rigid_cage_bodies(bearing, pocket_stiffness_n_m: float, pocket) -> list:
    """The rigid cage as bodies of the limit: (name, [(stiffness, reduced mass), ...], mass).

    Translation: every pocket pressing at once (Z springs on the cage mass, an upper bound: a
    ball-guided cage touches the balls that drive it and those it drives). Rotation: the same Z
    springs at the pitch radius on the polar inertia, i.e. on the mass I / r_p^2.
    ``pocket``: the BALL_POCKET row of contact_properties (its reduced mass damps the contact);
    ``pocket_stiffness_n_m``: the tangent stiffness at the cage contacts' force scale
    (:func:`cage_force_scale_n`: the pockets pass the chain force the cage balls would).
    """
    springs = [(pocket_stiffness_n_m, pocket.reduced_mass_kg)] * bearing.n_balls
    rotation_mass = bearing.rigid_cage_inertia_kg_m2 / bearing.pitch_radius_m**2
    return [
        ("rigid cage (translation)", springs, bearing.rigid_cage_mass_kg),
        ("rigid cage (rotation)", springs, rotation_mass),
    ]


#: Overlap of the chain's contact under the spin-up chain force, as a share of the smaller radius.
CHAIN_OVERLAP_FRACTION = 0.02
#: Pitch speed above which the spin-up lengthens with the speed (ball impacts on the cage), m/s.
SPIN_UP_SPEED_M_S = 5.0
#: Shortest automatic spin-up: the seed's (section 4), s.
SPIN_UP_MIN_S = 5.0e-3
#: Longest automatic spin-up, s: a weightless ring at zero load (no traction at all) would ask
#: for ever; 60 s is 6e8 steps at 1e-7 s, within the 1e9 a run may take.
SPIN_UP_MAX_S = 60.0
#: Share of the traction the spin-up asks of the ball/inner-race friction at its peak.
TRACTION_SHARE = 0.8
#: Clearance, as a share of the ball radius, that doubles the automatic spin-up.
CLEARANCE_SCALE_FRACTION = 0.02
#: Share of the stability limit an automatic time step uses.
DT_MARGIN = 0.9
#: Largest automatic time step: the accuracy the accuracy-cost study asks of the seed's scene
#: (docs/accuracy_cost/accuracy_cost.md: the paper's dt = 1e-7 s), s.
DT_ACCURACY_S = 1e-7


def chain_contact(scene) -> tuple[int, float]:
    """The contact type that carries the spin-up chain force and the radius its overlap is
    measured against: the ball/cage-ball contact and the cage-ball radius, the ball/pocket
    contact and the ball radius for a rigid cage, else ball/ball."""
    b = scene.bearing
    if scene.effects.cage == "balls":
        return BALL_CAGE, min(b.cage_ball_radius_m, b.ball_radius_m)
    if scene.effects.cage == "rigid":
        return BALL_POCKET, b.ball_radius_m
    return BALL_BALL, b.ball_radius_m


def auto_spin_up_time_s(scene) -> float:
    """Spin-up time for ``scene`` (see the module docstring), s, rounded up to 0.1 ms."""
    b, op = scene.bearing, scene.operating
    if scene.numerics.fidelity == "quasistatic":
        return SPIN_UP_MIN_S
    kind, radius = chain_contact(scene)
    coef, n = scene_law(scene)
    allowed_n = coef[kind] * (CHAIN_OVERLAP_FRACTION * radius) ** n
    omega_c = b.cage_speed_rad_s(op.omega_rad_s)
    inertia_mass = b.ball_mass_kg + b.ball_inertia_kg_m2 / b.ball_radius_m**2
    # chain_force_n = ceil(Z/2) m_eff r_p omega_c pi / (2 T): the T that passes allowed_n
    per_time = math.ceil(b.n_balls / 2) * inertia_mass * b.pitch_radius_m * omega_c * math.pi / 2
    speed = max(1.0, b.pitch_radius_m * omega_c / SPIN_UP_SPEED_M_S)
    rattle = 1.0 + max(op.clearance_m, 0.0) / (CLEARANCE_SCALE_FRACTION * b.ball_radius_m)
    t_spin = max(per_time / allowed_n * speed * rattle, traction_spin_up_time_s(scene))
    t_spin = min(SPIN_UP_MAX_S, max(SPIN_UP_MIN_S, t_spin))
    if t_spin == SPIN_UP_MIN_S:
        return t_spin
    return math.ceil(t_spin * 1e4 - 1e-9) * 1e-4


def traction_spin_up_time_s(scene) -> float:
    """Shortest sinusoidal spin-up the ball set can follow by rolling, s.

    The inner ring drives the balls by friction at the inner contacts only. A ball rolling on the
    outer race whose orbit accelerates at alpha_c needs ``f_i = r_p alpha_c (m_b + I_b/R_b^2)/2``
    there (orbit: ``f_i + f_o = m_b r_p alpha_c + P``; spin: ``f_o - f_i = -I_b r_p alpha_c /
    R_b^2``), and a cage of inertia J_c about the axis takes ``sum P = J_c alpha_c / r_p`` from
    the balls. Friction passes at most ``mu sum Q_i`` and ``sum Q_i >= |sum Q_i u_i|``: the
    radial load plus the ring's weight, or the preload force of every ball. The sinusoidal
    spin-up asks ``alpha_c = pi omega_c / (2 T)`` at its peak; at
    :data:`TRACTION_SHARE` of the friction available it is
    ``T = pi omega_c (Z r_p m_eff + J_c / r_p) / (4 share mu F_N)``. A shorter spin-up leaves the
    ball set sliding: at zero load the ring's weight alone drives it (measured, 6208 at
    351.6 rad/s after the seed's 5 ms: cage at 1.7 rad/s, then +68 rad/s^2, the rate this
    balance gives, to the kinematic 138.6 rad/s after 2.1 s; seed section 2.1: Coulomb friction
    on ball/raceway contacts only, so nothing else drives it). 0 without friction.
    """
    b, op, e = scene.bearing, scene.operating, scene.effects
    omega_c = abs(b.cage_speed_rad_s(op.omega_rad_s))
    if e.friction != "coulomb" or omega_c == 0.0:
        return 0.0
    m_eff = b.ball_mass_kg + b.ball_inertia_kg_m2 / b.ball_radius_m**2
    if e.cage == "balls":
        cage_inertia = b.n_balls * b.cage_ball_mass_kg * b.pitch_radius_m**2
    elif e.cage == "rigid":
        cage_inertia = b.rigid_cage_inertia_kg_m2
    else:
        cage_inertia = 0.0
    weight = b.inner_ring_mass_kg * STANDARD_GRAVITY_M_S2 if e.gravity == "standard" else 0.0
    coef, n = scene_law(scene)
    preload = b.n_balls * preload_ball_force_n(coef, n, op.clearance_m)
    normal = max(op.radial_load_n + weight, preload)
    inertia = b.n_balls * b.pitch_radius_m * m_eff + cage_inertia / b.pitch_radius_m
    traction = TRACTION_SHARE * b.friction_coefficient * normal
    if traction <= 0.0:
        return math.inf
    return math.pi * omega_c * inertia / (4.0 * traction)


def auto_dt_s(scene) -> float:
    """Time step for ``scene``: DT_MARGIN times its stability limit, at most DT_ACCURACY_S, on
    the grid of its record rate (:func:`record_grid_dt_s`), s."""
    dt_s = min(DT_ACCURACY_S, DT_MARGIN * stability_limit(scene).dt_limit_s)
    return record_grid_dt_s(dt_s, scene.numerics.sample_rate_hz)


def record_grid_dt_s(dt_s: float, sample_rate_hz: float) -> float:
    """The largest time step not above ``dt_s`` (to round-off) that divides the record period
    ``1 / sample_rate_hz`` a whole number of times, s.

    The kernel records every ``round(1 / (sample_rate_hz dt))`` steps, so a step off that grid
    records at another rate than asked (dt = 1.366e-6 s at 20 kHz: every 37 steps, 19782 Hz).
    On the grid, k steps per recorded instant, it records at the rate asked; the step shrinks by
    less than one part in k (the run costs that much more: under 3 % for the presets' ~1.4e-6 s
    at 20 kHz, k = 37), by up to half when the period is less than two steps, and to the period
    itself when it is shorter than the step (a rate above 1 / dt records every step: 2 MHz
    makes the fast preset's 1.5e-6 s 5e-7 s, three times the steps).
    """
    period_s = 1.0 / sample_rate_hz
    # a step that divides the period but for round-off is kept (1e-7 s at 20 kHz: 500 steps)
    steps = max(1, math.ceil(period_s / dt_s * (1.0 - 1e-12)))
    return min(dt_s, 1.0 / (sample_rate_hz * steps))
