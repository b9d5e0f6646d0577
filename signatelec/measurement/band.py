"""The ball-pass line a trace is read at: how many of its harmonics, how far from the kinematic
frequency it is searched, how many ball passes a trace needs, and the units a speed is given in
by mistake. Shared by the trace checks (:mod:`signatelec.measurement.traces`) and the ripple
search (:mod:`signatelec.measurement.ripple`)."""

from __future__ import annotations

import math

#: Harmonics of the ball-pass frequency the analysis fits by default (the quasi-static tier puts
#: the 5th and higher below 0.01 % of the level over 0.1-0.4 C_r, epsilon 0.3-0.6).
N_HARMONICS = 4
#: Half-width of the search for the ball-pass frequency around the kinematic one: the cage slip
#: of the DEM is -0.3 % to +0.1 %; a wider band lets noise peaks win for weak ripples.
SEARCH_REL = 0.01
#: Shortest trace, in ball passes (the harmonics need a few periods to stand out of the noise).
MIN_BALL_PASSES = 5.0
#: Units a speed is given in by mistake, for rad/s: their size in rad/s.
SPEED_UNITS = {"Hz": 2.0 * math.pi, "rpm": 2.0 * math.pi / 60.0}
