"""The kernel computes the contact laws of signatelec.contact (a same-code consistency guard).

One ball is pressed into the outer race with a known overlap and closing speed, and one
evaluation of the kernel's forces is compared with the pure functions of seed eqs 4, 5, 7-9.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import make_scene

from signatelec import contact
from signatelec.bearing import OUTER, contact_properties
from signatelec.dem import kernel_template as K
from signatelec.dem.kernels import KernelFlags, get_kernel
from signatelec.dem.simulate import KernelState, kernel_parameters


@pytest.mark.parametrize("law", ["hertz", "linear"])
def test_outer_contact_force_equals_contact_functions(law):
    scene = make_scene(
        radial_load_n=0.0,
        omega_rad_s=0.0,
        effects={"contact_law": law, "gravity": False, "electrical": False},
    )
    kern = get_kernel(KernelFlags.from_scene(scene))
    p = kernel_parameters(scene)
    st = KernelState.initial(scene)
    b = scene.bearing
    overlap, closing, slip = 20e-6, 0.05, 0.3
    # ball 0 at psi = 0 (bottom), pushed outwards by `overlap`, moving outwards and sliding
    st.pos[0] = (0.0, -(b.outer_race_radius_m - b.ball_radius_m + overlap))
    st.vel[0] = (slip, -closing)  # tangent t = perp(n) = (1, 0) at the bottom
    t_steady = 1.0  # after every set-up phase
    kern.forces(
        t_steady,
        p,
        st.pos,
        st.vel,
        st.spin,
        st.acc,
        st.spin_acc,
        st.xi,
        st.fcon,
        st.sched,
        st.energy,
        st.status,
        0,
    )
    props = contact_properties(b)[OUTER]
    coef = p[K.P_COEF + OUTER]
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
        contact.tangential_force(kt, slip * p[K.P_DT], ct, slip), fn, b.friction_coefficient
    )
    assert st.fcon[0, 3] == pytest.approx(ft, rel=1e-9)
    assert np.isclose(st.fcon[0, 0], 0.0)  # no inner contact at zero load


def test_hertz_critical_damping_closed_form():
    overlap = np.geomspace(1e-9, 1e-4, 20)
    c, m = 1.2e10, 8.2e-3
    direct = contact.critical_damping(contact.hertz_normal_stiffness(overlap, c), m)
    np.testing.assert_allclose(contact.hertz_critical_damping(overlap, c, m), direct, rtol=1e-13)
