"""The defects of a scene as the table the DEM kernel and the quasi-static tier read, and the
in-plane radii of the contacts they drop into: plain numpy, so that a run can build its
parameters without importing numba (the compiled surfaces are in :mod:`signatelec.physics.defects`).
"""

from __future__ import annotations

import numpy as np

#: Location codes of a defect (config.defects.LOCATIONS order) and of a contact side.
OUTER_RACE, INNER_RACE, BALL_SURFACE = 0, 1, 2
#: Contact sides: the ball on the inner or the outer race (config.bearing INNER, OUTER).
INNER_SIDE, OUTER_SIDE = 0, 1
#: Rows of a defect table (:func:`defect_table`), one column per defect.
LOCATION, CENTRE, HALF_LENGTH, DEPTH, BALL, SMOOTH, SURFACE_RADIUS = range(7)
TABLE_ROWS = 7


def defect_table(scene, width: int | None = None) -> np.ndarray:
    """The scene's defects as a (TABLE_ROWS, width) array (default width: their number)."""
    b = scene.bearing
    codes = {"outer": OUTER_RACE, "inner": INNER_RACE, "ball": BALL_SURFACE}
    radii = {
        "outer": b.outer_race_radius_m + scene.operating.clearance_m,
        "inner": b.inner_race_radius_m,
        "ball": b.ball_radius_m,
    }
    table = np.zeros((TABLE_ROWS, len(scene.defects) if width is None else width))
    for j, d in enumerate(scene.defects):
        table[LOCATION, j] = codes[d.location]
        table[CENTRE, j] = d.angle_rad
        table[HALF_LENGTH, j] = 0.5 * d.length_m
        table[DEPTH, j] = d.depth_m
        table[BALL, j] = d.ball
        table[SMOOTH, j] = d.profile == "smooth"
        table[SURFACE_RADIUS, j] = radii[d.location]
    return table


def contact_radii_m(bearing) -> tuple[float, float]:
    """In-plane equivalent radii of the ball on the inner and on the outer race, m:
    1/R = 1/R_b + 1/R_inn (convex on convex) and 1/R_b - 1/R_out (in the concave outer race)."""
    rb, ri, ro = bearing.ball_radius_m, bearing.inner_race_radius_m, bearing.outer_race_radius_m
    return rb * ri / (rb + ri), rb * ro / (ro - rb)
