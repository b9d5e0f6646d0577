"""Load regimes of a radial bearing: preload, zero clearance or clearance.

The regime is the sign of the radial clearance Delta_r = R_out^f - R_out (seed eq. 14), with a
tolerance: within +-1 um of zero a bearing is "zero" (the seed's Delta_r = 0, epsilon = 0.5).
In terms of the load parameter epsilon (seed eq. 15) a clearance gives epsilon < 0.5, none
0.5 and a preload epsilon > 0.5. Datasets partition their traces by regime and the estimator
classifies a trace into one.
"""

from __future__ import annotations

import math

#: The regimes, from the tightest to the loosest bearing.
REGIMES = ("preload", "zero", "clearance")
#: Half-width of the "zero" regime around Delta_r = 0, m.
REGIME_TOLERANCE_M = 1e-6


def regime_of(clearance_m: float) -> str:
    """The regime of a radial clearance (< 0: a preload), m."""
    if clearance_m < -REGIME_TOLERANCE_M:
        return "preload"
    if clearance_m > REGIME_TOLERANCE_M:
        return "clearance"
    return "zero"


def regime_of_epsilon(epsilon: float) -> str:
    """The regime a load parameter epsilon (seed eq. 15) stands for: 0.5 means Delta_r = 0."""
    if math.isnan(epsilon):
        raise ValueError("epsilon = nan: a regime needs a load parameter")
    if epsilon == 0.5:
        return "zero"
    return "clearance" if epsilon < 0.5 else "preload"
