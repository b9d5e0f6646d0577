"""The kernel computes the contact laws of signatelec.physics.contact (a same-code consistency
guard).

One ball is pressed into the outer race with a known overlap and closing speed, and one
evaluation of the kernel's forces is compared with the pure functions of seed eqs 4, 5, 7-9.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import make_scene

from signatelec.config.bearing import OUTER, contact_properties
from signatelec.engines.dem.build import get_kernel
from signatelec.engines.dem.run import initial_state, kernel_parameters
from signatelec.engines.dem.spec import KernelSpec
from signatelec.physics import contact


@pytest.mark.parametrize("law", ["hertz", "linear"])
def test_outer_contact_force_equals_contact_functions(law):
    scene = make_scene(
        radial_load_n=0.0,
        omega_rad_s=0.0,
        effects={"contact_law": law, "gravity": "none"},
        outputs={"electrical": False},
    )
    kern = get_kernel(KernelSpec.from_scene(scene))
    p = kernel_parameters(scene)
    st = initial_state(scene)
    b = scene.bearing
    overlap, closing, slip = 20e-6, 0.05, 0.3
    # ball 0 at psi = 0 (bottom), pushed outwards by `overlap`, moving outwards and sliding
    st.pos[0] = (0.0, -(b.outer_race_radius_m - b.ball_radius_m + overlap))
    st.vel[0] = (slip, -closing)  # tangent t = perp(n) = (1, 0) at the bottom
    t_steady = 1.0  # after every set-up phase
    kern.forces(t_steady, p, st, st.acc, 0)
    props = contact_properties(b)[OUTER]
    coef = p["normal_coefficient"][OUTER]
    if law == "hertz":
        fe = contact.hertz_normal_force(overlap, coef)
        cn = contact.critical_damping(
            contact.hertz_normal_stiffness(overlap, coef), props.reduced_mass_kg
        )
        kt = contact.mindlin_tangential_stiffness(
            fe, props.radius_eq_m, props.shear_modulus_pa, props.poisson
        )
    else:
        fe = contact.linear_normal_force(overlap, coef)
        cn = contact.critical_damping(coef, props.reduced_mass_kg)
        kt = 2.0 / 3.0 * coef
    fn = contact.damped_normal_force(fe, cn, closing)
    assert st.fcon[0, 1] == pytest.approx(fn, rel=1e-12)
    ct = contact.critical_damping(kt, props.reduced_mass_kg)
    ft = contact.coulomb_limit(
        contact.tangential_force(kt, slip * p["dt_s"], ct, slip), fn, b.friction_coefficient
    )
    assert st.fcon[0, 3] == pytest.approx(ft, rel=1e-9)
    assert np.isclose(st.fcon[0, 0], 0.0)  # no inner contact at zero load


def test_hertz_critical_damping_closed_form():
    overlap = np.geomspace(1e-9, 1e-4, 20)
    c, m = 1.2e10, 8.2e-3
    direct = contact.critical_damping(contact.hertz_normal_stiffness(overlap, c), m)
    np.testing.assert_allclose(contact.hertz_critical_damping(overlap, c, m), direct, rtol=1e-13)


def test_warm_started_roots_equal_cold_ones():
    """The kernel's roots warm-started from the steps before (kernel.rsqrt_warm,
    rquart_warm) give the forces a cold start gives, to rounding, on every contact type.

    Rounding here: a few ulp of the centre distance d, which the overlap reach - d amplifies by
    d / delta ~ 1e4, so forces agree to 1e-10 relative (they differ by ~3e-12)."""
    scene = make_scene(outputs={"electrical": False})
    kern = get_kernel(KernelSpec.from_scene(scene))
    p = kernel_parameters(scene)
    warm = initial_state(scene)
    b = scene.bearing
    rng = np.random.default_rng(7)
    # squeeze every contact: balls 3 um onto the outer race, the ring 10 um down onto the lower
    # balls, cage balls 1-3 um off the pitch circle and turned 10 um onto ball j (even j) or
    # ball j + 1 (odd j), across their 4.5 um gaps
    z = b.n_balls
    rp = b.pitch_radius_m
    warm.pos[:z] *= 1.0 + 3e-6 / rp
    warm.pos[2 * z] = (0.0, -10e-6)
    turn = np.where(np.arange(z) % 2 == 0, -1.0, 1.0) * 10e-6 / rp
    c, s_ = np.cos(turn), np.sin(turn)
    x, y = warm.pos[z : 2 * z].T.copy()
    radial = 1.0 + rng.uniform(1e-6, 3e-6, z) * rng.choice([-1.0, 1.0], z) / rp
    warm.pos[z : 2 * z, 0] = (c * x - s_ * y) * radial
    warm.pos[z : 2 * z, 1] = (s_ * x + c * y) * radial
    warm.vel[:] = rng.normal(0.0, 1e-3, warm.vel.shape)

    def evaluate(state):
        kern.forces(1.0, p, state, state.acc, 0)
        return state.fcon.copy(), state.acc.copy()

    for step in range(4):
        # a smooth motion with steps of 1e-10 m to 1e-8 m, like dt = 1e-7 s at mm/s to cm/s
        warm.pos[:] += warm.vel * 1e-7 * (1.0 + step) + rng.normal(0.0, 1e-11, warm.pos.shape)
        fcon_warm, acc_warm = evaluate(warm)
        cold = initial_state(scene)
        cold.pos[:], cold.vel[:] = warm.pos, warm.vel
        fcon_cold, acc_cold = evaluate(cold)
        touching = np.count_nonzero(fcon_cold, axis=0)
        assert touching[0] >= 3 and touching[1] == z and touching[4] + touching[5] >= z
        np.testing.assert_allclose(fcon_warm, fcon_cold, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(acc_warm, acc_cold, rtol=1e-10, atol=1e-6)
    assert np.any(warm.roots[:, 10:] > 0.0)  # the extrapolation had a step before
