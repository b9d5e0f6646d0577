"""The stability limit of the kernel's schemes (von Neumann analysis) and of a scene."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import make_scene

from signatelec.physics.stability import damped_step_limit, stability_limit


def spectral_radius(integrator: str, h: float, zeta: float, omega: float = 1.0) -> float:
    """Largest |eigenvalue| of one step of x'' = -omega^2 x - 2 zeta omega x' as the kernel
    integrates it: Verlet with damping at the predicted velocity v + a h, or symplectic Euler."""
    size = 3 if integrator == "verlet" else 2
    m = np.zeros((size, size))
    for j in range(size):
        s = np.zeros(size)
        s[j] = 1.0
        if integrator == "verlet":
            x, v, a = s
            x1 = x + h * v + 0.5 * h * h * a
            vp = v + h * a
            a1 = -omega * omega * x1 - 2 * zeta * omega * vp
            m[:, j] = (x1, vp + 0.5 * h * (a1 - a), a1)
        else:
            x, v = s
            v1 = v + h * (-omega * omega * x - 2 * zeta * omega * v)
            m[:, j] = (x + h * v1, v1)
    return float(np.abs(np.linalg.eigvals(m)).max())


@pytest.mark.parametrize("integrator", ["verlet", "euler"])
@pytest.mark.parametrize("zeta", [0.0, 0.3, 1.0, 1.6, 2.2])
def test_step_limit_is_the_edge_of_stability(integrator, zeta):
    # The closed-form limit is where the spectral radius crosses 1: measured within 3.6e-15 of
    # the root of the amplification matrix's radius (brentq), so it is bracketed at +-1.5e-14.
    # Below, |lambda| <= 1 up to the eigenvalues' round-off (measured 6.7e-16 above 1, undamped);
    # above, |lambda| - 1 grows like the step's excess times 1.4-2.6 (damped) or its square root
    # (undamped): at least 1.4e-14, measured.
    h = damped_step_limit(1.0, zeta, integrator)
    assert spectral_radius(integrator, (1.0 - 1.5e-14) * h, zeta) <= 1.0 + 2e-15
    assert spectral_radius(integrator, (1.0 + 1.5e-14) * h, zeta) > 1.0 + 4e-15


def test_the_papers_time_step_is_within_the_limit_of_the_seed_scene():
    """The seed ran at dt = 1e-7 s (section 4): the estimate must not refuse it."""
    for law in ("hertz", "harris", "linear"):
        assert stability_limit(make_scene(effects={"contact_law": law})).dt_limit_s >= 1e-7
