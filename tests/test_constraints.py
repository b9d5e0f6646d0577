"""The constraint table and its checker: every row names a real key, every named limit is
supplied, numbers are compared before they are converted, and the physics rules agree with the
geometry and the Hertz theory they stand for."""

from __future__ import annotations

import math
import string
import sys
from dataclasses import fields

import pytest

from signatelec.config import constraints as C
from signatelec.config.bearing import INNER, OUTER, Bearing, BearingError, Material
from signatelec.config.scene import AUTO, Scene, SceneError, scene_limits
from signatelec.measurement.model import MeasurementModel
from signatelec.physics.contact import hertz_overlap, law_coefficients


def named_limits(rows) -> set[str]:
    """The limits the rows name: in bounds, choices, rules and the fields of their texts."""
    names = set()
    for row in rows:
        for ref in (row.low, row.high, row.choices, row.rule):
            if isinstance(ref, C.Limit):
                names.add(ref.name)
        for _, field, _, _ in string.Formatter().parse(row.allowed):
            if field and field not in ("value", "low", "high", "choices"):
                names.add(field.split(".")[0])
    return names


def test_scene_rows_name_number_fields_and_every_limit_is_supplied():
    scene = Scene()
    for row in C.SCENE:
        field = {f.name: f for f in fields(getattr(scene, row.section))}[row.key]
        # a number, or "auto" (a number the scene chooses: it is a number once the scene is built)
        assert isinstance(field.default, float) or field.default == AUTO, row.name
        assert isinstance(getattr(getattr(scene, row.section), row.key), float), row.name
        assert row.kind == C.NUMBER, row.name
    assert named_limits(C.SCENE) <= set(scene_limits(scene))


def test_spec_rows_cover_the_measurement_model_and_its_types():
    model = {f.name: f.default for f in fields(MeasurementModel)}
    assert [row.key for row in C.MEASUREMENT] == list(model)
    kinds = {bool: C.BOOLEAN, int: C.INTEGER, float: C.NUMBER, tuple: C.INTERVAL}
    for row in C.MEASUREMENT:
        assert row.kind == kinds[type(model[row.key])], row.name


def test_bearing_rows_name_bearing_and_material_fields():
    assert {row.key for row in C.BEARING} <= {f.name for f in fields(Bearing)}
    assert [row.key for row in C.MATERIAL] == [f.name for f in fields(Material)]


def test_numbers_are_compared_as_given_not_converted():
    check = C.Checker()
    bounded = C.Constraint("s", "x", C.NUMBER, 0.0, 10.0)
    free = C.Constraint("s", "x", C.NUMBER)
    beyond_float = 2**1024  # the first integer above the largest float, 1.797e308
    with pytest.raises(C.ConstraintError, match=r"s\.x = 1797.*: must be in \[0, 10\]"):
        check.check(bounded, beyond_float)
    with pytest.raises(C.ConstraintError, match="must be a finite number"):
        check.check(free, beyond_float)
    largest = int(sys.float_info.max)
    assert check.check(free, largest) == sys.float_info.max
    with pytest.raises(C.ConstraintError, match="must be an integer in"):
        check.check(C.Constraint("s", "n", C.INTEGER, 1, 64), 10**400)
    for bad in (True, "1", None, [1.0]):
        with pytest.raises(C.ConstraintError, match="must be a number"):
            check.check(free, bad)


def test_open_closed_bounds_and_intervals():
    check = C.Checker()
    half_open = C.Constraint("s", "x", C.NUMBER, 0.0, 1.0, low_open=True)
    assert check.check(half_open, 1) == 1.0
    with pytest.raises(C.ConstraintError, match=r"must be in \(0, 1\]"):
        check.check(half_open, 0.0)
    interval = C.Constraint("s", "r", C.INTERVAL, 0.0, 1.0)
    assert check.check(interval, 0.5) == (0.5, 0.5)
    assert check.check(interval, [0.1, 0.2]) == (0.1, 0.2)
    with pytest.raises(C.ConstraintError, match="low <= high"):
        check.check(interval, [0.2, 0.1])
    with pytest.raises(C.ConstraintError, match=r"s\.r\[1\] = inf: must be a finite number"):
        check.check(interval, [0.1, math.inf])


def test_limits_are_evaluated_once_and_only_when_needed():
    calls = []

    def limit():
        calls.append(1)
        return 2.0

    check = C.Checker(limits={"cap": limit})
    row = C.Constraint("s", "x", C.NUMBER, high=C.Limit("cap"), allowed="must be <= {high:g}")
    assert calls == []
    check.check(row, 1.0)
    check.check(row, 1.5)
    assert calls == [1]
    with pytest.raises(C.ConstraintError, match=r"s\.x = 3\.0: must be <= 2$"):
        check.check(row, 3.0)


def test_the_6208_holds_13_balls_and_cage_balls_at_most():
    """Balls and cage balls alternate on the pitch circle: 2 r_p sin(pi / 2Z) >= R_b + R_c gives
    Z <= pi / (2 asin((R_b + R_c) / 2 r_p)) = 13.01 for the seed's 6208 (table 1)."""
    b = Bearing()
    z_max = math.pi / (2.0 * math.asin((b.ball_radius_m + b.cage_ball_radius_m) / (2 * 30.3e-3)))
    assert 13.0 < z_max < 13.1
    assert b.with_(n_balls=13).n_balls == 13
    with pytest.raises(BearingError, match="bearing.n_balls = 14: 14 balls .* do not fit"):
        b.with_(n_balls=14)


def test_load_limit_is_a_hertz_overlap_of_5_percent_of_the_ball_radius():
    """At the largest F_r a scene accepts, Stribeck's ball load 4.37 F_r / Z overlaps the more
    compliant raceway by 5 % of R_b (Hertz, seed eqs 6 and 8)."""
    b = Bearing()
    limit = scene_limits(Scene())["radial_load_limit_n"]()
    coef, _ = law_coefficients(b, "hertz")
    q = 4.37 * limit / b.n_balls
    overlap = max(hertz_overlap(q, coef[i]) for i in (INNER, OUTER))
    assert overlap == pytest.approx(0.05 * b.ball_radius_m, rel=1e-9)
    Scene().with_overrides(radial_load_n=limit)
    with pytest.raises(SceneError, match="operating.radial_load_n = .*: must be <= "):
        Scene().with_overrides(radial_load_n=limit * 1.0001)


def test_time_step_bounds_keep_the_step_count_a_64_bit_integer():
    finest = Scene().with_overrides(dt_s=C.DT_MIN_S, duration_s=C.DURATION_MAX_S)
    assert finest.n_steps == round(C.DURATION_MAX_S / C.DT_MIN_S) < 2**63
    for dt in (5e-324, 1e-300, 0.999e-12):
        with pytest.raises(SceneError, match=r"numerics.dt_s = .*: must be >= 1e-12 s"):
            Scene().with_overrides(dt_s=dt)
