"""The bearing catalogue against geometry, Stribeck's constant, ISO 281 and the published figures.

Expected values come from the load-distribution theory (Stribeck's Z Q_max / F_r = 4.37 at zero
clearance, Harris 2001 section 7.3), ISO 281:2007 (basic dynamic load rating of a deep-groove
ball bearing from its ball set), the boundary dimensions of ISO 15 and the data sets' published
geometry; each tolerance says where it comes from.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from signatelec.config.bearing import STEEL, Bearing, BearingError, validate_bearing
from signatelec.config.catalogue import (
    CATALOGUE,
    CatalogueError,
    catalogue_bearing,
    catalogue_entry,
    list_bearings,
    minimum_load_n,
)
from signatelec.physics.kinematics import characteristic_orders
from signatelec.physics.quasistatic import ball_angles_rad, solve_equilibrium

DESIGNATIONS = list(CATALOGUE)
REAL = [d for d in DESIGNATIONS if d != "seed"]


@pytest.mark.parametrize("designation", DESIGNATIONS)
def test_every_entry_builds_a_bearing_whose_balls_and_cage_fit(designation):
    b = catalogue_bearing(designation)
    validate_bearing(b)
    rp = b.pitch_radius_m
    # neighbouring balls 2 pi / Z apart on the pitch circle must not touch
    assert 2.0 * rp * math.sin(math.pi / b.n_balls) > 2.0 * b.ball_radius_m
    # a cage ball at mid-angle must clear both balls, and its boundaries r_p -+ R_c must stay
    # between the races (r_p -+ R_b)
    assert 2.0 * rp * math.sin(math.pi / (2 * b.n_balls)) > b.ball_radius_m + b.cage_ball_radius_m
    assert b.cage_ball_radius_m < b.ball_radius_m
    # deep-groove conformities r_groove / D of real bearings lie in 0.51-0.54 (Harris 2001, 2.3)
    for groove in (b.inner_groove_radius_m, b.outer_groove_radius_m):
        assert 0.51 <= groove / (2.0 * b.ball_radius_m) <= 0.54


@pytest.mark.parametrize("designation", REAL)
def test_cage_balls_fill_the_gap_as_the_seeds_do(designation):
    # seed table 1: a 1.00 mm cage ball between 13 balls of radius 6.3 mm on a 30.3 mm pitch radius
    # fills 99.5 % of the gap 2 r_p sin(pi / 2Z) - R_b. The catalogue keeps that fill: with 10 %
    # play the ball set oscillates after the spin-up and the steady state strays 1-5 % from the
    # quasi-static tier (evenly spaced balls), tests/test_operating_map.py.
    def fill(b):
        gap_m = 2.0 * b.pitch_radius_m * math.sin(math.pi / (2 * b.n_balls)) - b.ball_radius_m
        return b.cage_ball_radius_m / gap_m

    seed = Bearing()
    assert seed.cage_ball_radius_m == 1.00e-3 and fill(seed) == pytest.approx(0.995, abs=5e-4)
    assert fill(catalogue_bearing(designation)) == pytest.approx(fill(seed), abs=1e-3)


def test_the_seed_entry_is_the_seed_bearing():
    assert catalogue_bearing() == Bearing()
    assert catalogue_bearing(" SEED ", friction_coefficient=0.1) == Bearing().with_(
        friction_coefficient=0.1
    )


@pytest.mark.validation
@pytest.mark.parametrize("designation", DESIGNATIONS)
def test_stribeck_constant_at_zero_clearance(designation):
    # Stribeck: Z Q_max / F_r = 4.37 at zero clearance, Q_max on the ball at the load line
    # (Harris 2001, 7.3). With a finite Z the exact sum Z / sum cos^2.5 psi is within 1 % of it
    # for Z >= 7 (7 balls: 4.337, 8: 4.346, 9: 4.385, 13: 4.374), so 2 % holds it with room.
    b = catalogue_bearing(designation)
    radial_load_n = 0.1 * b.dynamic_load_rating_n
    psi = ball_angles_rad(b.n_balls)
    state = solve_equilibrium(psi, b, radial_load_n, 0.0, 0.0, centrifugal=False)
    assert state.epsilon == 0.5
    assert b.n_balls * state.max_inner_force_n / radial_load_n == pytest.approx(4.37, rel=0.02)


# The CWRU drive-end SKF 6205 has a published pitch of 1.537 in = 39.04 mm, 1.40 % above the
# 38.5 mm mean of its bore and outside diameter: the outer ring is the thinner one. Every other
# entry is within 1 % (the seed's 2D model sits on the limit: 60.6 mm for a 60 mm mean).
PITCH_REL = {"6205": 0.015}


@pytest.mark.validation
@pytest.mark.parametrize("designation", DESIGNATIONS)
def test_pitch_diameter_is_near_the_mean_of_bore_and_outside_diameter(designation):
    e = catalogue_entry(designation)
    mean_m = 0.5 * (e.bore_diameter_m + e.outside_diameter_m)
    assert e.pitch_diameter_m == pytest.approx(mean_m, rel=PITCH_REL.get(designation, 0.01 + 1e-12))
    # and the rings keep a wall between the bore (or outside) and the groove bottom
    b = catalogue_bearing(designation)
    assert b.inner_race_radius_m > 0.5 * e.bore_diameter_m
    assert b.outer_race_radius_m < 0.5 * e.outside_diameter_m


# ISO 281:2007 table 2, f_c of single-row radial-contact groove ball bearings against
# gamma = D cos(alpha) / d_m (N and mm), in the range the catalogue covers.
ISO281_GAMMA = [0.14, 0.16, 0.18, 0.20, 0.22, 0.24, 0.26, 0.28, 0.30]
ISO281_FC = [58.8, 59.6, 59.9, 59.9, 59.6, 59.0, 58.2, 57.1, 56.0]
ISO281_BM = 1.3  # rating factor b_m of deep-groove ball bearings, ISO 281:2007 table 1


def iso281_dynamic_rating_n(n_balls: int, ball_diameter_m: float, pitch_diameter_m: float):
    """C_r = b_m f_c Z^(2/3) D^1.8 (D <= 25.4 mm, one row, alpha = 0), ISO 281:2007 eq. 2."""
    gamma = ball_diameter_m / pitch_diameter_m
    fc = float(np.interp(gamma, ISO281_GAMMA, ISO281_FC))
    return ISO281_BM * fc * n_balls ** (2.0 / 3.0) * (ball_diameter_m * 1e3) ** 1.8


@pytest.mark.validation
def test_iso281_reproduces_the_nsk_ratings_of_the_standard_ball_sets():
    # NSK rates to ISO 281: 6203 9.55 kN, 6204 12.8 kN, 6206 19.5 kN. The standard ball sets of
    # the catalogue (8 x 0.2656 in, 8 x 5/16 in, 9 x 3/8 in) reproduce them to the 3 figures given.
    for designation, nsk_n in (("6203", 9550.0), ("6204", 12800.0), ("6206", 19500.0)):
        e = catalogue_entry(designation)
        rating = iso281_dynamic_rating_n(e.n_balls, e.ball_diameter_m, e.pitch_diameter_m)
        assert rating == pytest.approx(nsk_n, rel=0.005)


@pytest.mark.validation
@pytest.mark.parametrize("designation", REAL)
def test_published_rating_matches_the_ball_set_under_iso281(designation):
    # Manufacturers publish ratings at or a few per cent above the ISO 281 value of their ball
    # set (SKF: -0.3 to +5.5 % for these entries; the 6305 ball set was chosen by this
    # criterion, see its source); one ball more or fewer moves the ISO value by 8-10 %
    # ((Z +- 1) / Z)^(2/3), which this band would catch. The seed's 13-ball 2D model is no real
    # ball set (ISO 281 gives it 41 kN against the 29.1 kN it quotes), so it is left out.
    e = catalogue_entry(designation)
    rating = iso281_dynamic_rating_n(e.n_balls, e.ball_diameter_m, e.pitch_diameter_m)
    assert 0.97 <= e.dynamic_load_rating_n / rating <= 1.07


@pytest.mark.validation
@pytest.mark.parametrize("designation", REAL)
def test_catalogue_mass_matches_the_geometry(designation):
    # Rings as steel annuli (bore to groove bottom, groove bottom to outside diameter, full width)
    # plus the balls leave out the ring shoulders, the cage and the seals: 3/4 of the catalogue
    # mass for every entry (0.73-0.77); 0.65-0.85 catches a wrong unit or dimension.
    e = catalogue_entry(designation)
    b = catalogue_bearing(designation)
    outer_ring_kg = (
        STEEL.density_kg_m3
        * math.pi
        * ((0.5 * e.outside_diameter_m) ** 2 - b.outer_race_radius_m**2)
        * e.width_m
    )
    total_kg = b.inner_ring_mass_kg + outer_ring_kg + b.n_balls * b.ball_mass_kg
    assert 0.65 <= total_kg / e.mass_kg <= 0.85
    assert b.inner_ring_mass_kg < e.mass_kg


@pytest.mark.validation
def test_6203_geometry_agrees_with_the_paderborn_kat_6203():
    # Paderborn KAt data set: 6203 with 8 balls of 6.75 mm on a 28.55 mm pitch; the catalogue's
    # CWRU geometry (6.746 mm, 28.50 mm) agrees within 0.2 %.
    e = catalogue_entry("6203")
    assert e.n_balls == 8
    assert e.ball_diameter_m == pytest.approx(6.75e-3, rel=0.002)
    assert e.pitch_diameter_m == pytest.approx(28.55e-3, rel=0.002)


def test_real_6208_raceways():
    # 9 balls of 12.7 mm, inner and outer raceway radii 23.65 and 36.35 mm (zero clearance)
    b = catalogue_bearing("6208")
    assert b.n_balls == 9
    assert 2.0 * b.ball_radius_m == pytest.approx(12.7e-3, rel=1e-12)
    assert b.inner_race_radius_m == pytest.approx(23.65e-3, rel=1e-12)
    assert b.outer_race_radius_m == pytest.approx(36.35e-3, rel=1e-12)


def test_overriding_the_ball_set_rederives_the_dependent_fields():
    b = catalogue_bearing("6208", n_balls=8)
    base = catalogue_bearing("6208")
    assert b.n_balls == 8
    assert b.outer_race_radius_m == pytest.approx(b.inner_race_radius_m + 2 * b.ball_radius_m)
    assert b.cage_ball_radius_m > base.cage_ball_radius_m  # wider gaps, larger spacers
    bigger = catalogue_bearing("6208", ball_radius_m=7e-3)
    assert bigger.outer_race_radius_m == pytest.approx(bigger.inner_race_radius_m + 14e-3)
    assert bigger.inner_groove_radius_m == pytest.approx(0.52 * 14e-3)
    kept = catalogue_bearing("6208", n_balls=8, cage_ball_radius_m=2e-3)
    assert kept.cage_ball_radius_m == 2e-3
    assert catalogue_bearing("6205", cage_material="steel").cage_material == STEEL


@pytest.mark.parametrize(
    ("args", "overrides", "message"),
    [
        (("6209",), {}, r"bearing.designation = '6209': unknown bearing; known: seed, 6203"),
        (("6205",), {"balls": 9}, r"bearing.balls = 9: unknown key; allowed: "),
        (("6205",), {"n_balls": 30}, r"bearing.n_balls = 30: 30 balls .* leave no room"),
        (("6205",), {"n_balls": 2.5}, r"bearing.n_balls = 2.5: must be an integer >= 3"),
        (("6205",), {"ball_radius_m": -1e-3}, r"bearing.ball_radius_m = -0.001: must be"),
        (("6205",), {"cage_ball_radius_m": 5e-3}, r"bearing.n_balls = 9: 9 balls"),
    ],
)
def test_bad_designation_or_override_is_one_clear_line(args, overrides, message):
    with pytest.raises(BearingError, match=message) as info:
        catalogue_bearing(*args, **overrides)
    assert "\n" not in str(info.value)
    if "designation" in message or "unknown key" in message:
        assert isinstance(info.value, CatalogueError)


def test_list_bearings_is_a_table_with_sources_and_orders():
    table = list_bearings()
    assert list(table.index) == DESIGNATIONS
    for column in ("geometry_source", "ratings_source"):
        assert table[column].str.len().min() > 0
    for column in ("ftf_order", "bpfo_order", "bpfi_order", "bsf_order", "limiting_speed_rad_s"):
        assert column in table.columns
    # BPFO + BPFI = Z orders for every entry (each ball passes both races once per relative turn)
    total = table["bpfo_order"] + table["bpfi_order"]
    np.testing.assert_allclose(total, table["n_balls"].astype(float), rtol=1e-14)


# Published rows, SI units: (d, D_o, B) m, C_r and C_0r N, reference and limiting speed r/min, mass
# kg. SKF, Rolling bearings, PUB BU/P1 17000/1 EN (2018), product table 1.1, rows 6203 and 6205
# ("17 40 12 9,95 4,75 0,2 38 000 24 000 0,065 * 6203", "25 52 15 14,8 7,8 0,335 28 000 18 000
# 0,13 * 6205"; docs/catalogue_sources.md gives where each was read).
SKF_2018_ROWS = {
    "6203": ((17e-3, 40e-3, 12e-3), 9950.0, 4750.0, 38000.0, 24000.0, 0.065),
    "6205": ((25e-3, 52e-3, 15e-3), 14800.0, 7800.0, 28000.0, 18000.0, 0.13),
}


@pytest.mark.validation
@pytest.mark.parametrize("designation", SKF_2018_ROWS)
def test_skf_catalogue_rows_of_the_cwru_bearings(designation):
    # The catalogue states the published values themselves: equal up to the kN -> N conversion.
    dims_m, c_n, c0_n, ref_rpm, lim_rpm, mass_kg = SKF_2018_ROWS[designation]
    e = catalogue_entry(designation)
    got = (e.bore_diameter_m, e.outside_diameter_m, e.width_m)
    assert got == pytest.approx(dims_m, rel=1e-12)
    assert e.dynamic_load_rating_n == pytest.approx(c_n, rel=1e-12)
    assert e.static_load_rating_n == pytest.approx(c0_n, rel=1e-12)
    assert (e.reference_speed_rpm, e.limiting_speed_rpm) == (ref_rpm, lim_rpm)
    assert e.mass_kg == pytest.approx(mass_kg, rel=1e-12)


@pytest.mark.validation
@pytest.mark.parametrize(
    ("designation", "c_n", "c0_n"), [("6206", 20300.0, 11200.0), ("6305", 23400.0, 11600.0)]
)
def test_ratings_agree_with_the_skf_shielded_rows(designation, c_n, c0_n):
    # SKF capped deep groove ball bearings, table 1.2 (PDF pp. 63, 65): 6206-2Z and 6305-2Z. A
    # shield leaves the ball set, hence C_r and C_0r, unchanged: the same table gives the 6203-2Z
    # and 6205-2Z exactly the open rows' ratings (SKF 2018, table 1.1).
    e = catalogue_entry(designation)
    assert e.dynamic_load_rating_n == pytest.approx(c_n, rel=1e-12)
    assert e.static_load_rating_n == pytest.approx(c0_n, rel=1e-12)


def test_seed_quotes_the_nsk_and_skf_ratings_of_the_6208():
    # seed 2.2.2: "for a 6208, NSK gives C_r = 29100N and SKF gives C_r = 32500N"
    assert catalogue_entry("seed").dynamic_load_rating_n == 29100.0
    assert catalogue_entry("6208").dynamic_load_rating_n == 32500.0


@pytest.mark.validation
def test_6205_boundary_dimensions_are_the_cwru_size_table():
    # CWRU Bearing Data Center, bearing information: 6205-2RS JEM inside diameter 0.9843 in,
    # outside diameter 2.0472 in, thickness 0.5906 in. Four decimals: within 0.00005 in.
    e = catalogue_entry("6205")
    inch_m = 25.4e-3
    for ours_m, published_in in zip(
        (e.bore_diameter_m, e.outside_diameter_m, e.width_m), (0.9843, 2.0472, 0.5906), strict=True
    ):
        assert abs(ours_m / inch_m - published_in) <= 0.00005


# Smith and Randall, Mech. Syst. Signal Process. 64-65 (2015), table 2 (from the CWRU geometry):
# BPFI, BPFO, FTF, BSF as orders of the shaft speed. Their BSF is the ball spin, half of the CWRU
# "rolling element" multiplier (4.7135, 3.9874) that tests/test_kinematics.py checks.
SMITH_RANDALL_ORDERS = {
    "6205": {"bpfi": 5.415, "bpfo": 3.585, "ftf": 0.3983, "bsf": 2.357},
    "6203": {"bpfi": 4.947, "bpfo": 3.053, "ftf": 0.3816, "bsf": 1.994},
}


@pytest.mark.validation
@pytest.mark.parametrize("designation", SMITH_RANDALL_ORDERS)
def test_orders_are_smith_and_randalls_for_the_cwru_bearings(designation):
    # Printed to 4 significant figures: the tolerance is half a unit of the last digit.
    orders = characteristic_orders(catalogue_bearing(designation), 0.0)
    for key, published in SMITH_RANDALL_ORDERS[designation].items():
        half_unit = 0.5 * 10.0 ** (math.floor(math.log10(published)) - 3)
        assert abs(orders[key] - published) <= half_unit, key


def test_minimum_load_follows_the_skf_rule():
    # SKF Rolling bearings 17000/1 EN (2018), deep groove ball bearings, requisite minimum load:
    # F_rm = k_r (nu n / 1000)^(2/3) (d_m / 100)^2 kN with k_r = 0.025 (62 series; the product
    # table's value for the 6208) and 0.03 (63 series, 6308); d_m = (d + D) / 2.
    rpm = 2.0 * np.pi / 60.0  # rad/s per r/min
    # 6208: d_m = (40 + 80) / 2 = 60 mm; nu n = 1000 -> 0.025 * 0.6^2 kN = 9.0 N
    assert minimum_load_n("6208", 10.0, 100.0 * rpm) == pytest.approx(9.0, rel=1e-12)
    # 6308: d_m = (40 + 90) / 2 = 65 mm -> 0.03 * 0.65^2 kN = 12.675 N
    assert minimum_load_n("6308", 10.0, 100.0 * rpm) == pytest.approx(12.675, rel=1e-12)
    # (nu n)^(2/3): eight times the speed, four times the load
    assert minimum_load_n("6205", 68.0, 800.0 * rpm) == pytest.approx(
        4.0 * minimum_load_n("6205", 68.0, 100.0 * rpm), rel=1e-12
    )
    assert minimum_load_n("seed", 68.0, 100.0) == minimum_load_n("6208", 68.0, 100.0)
