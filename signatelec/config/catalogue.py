"""A catalogue of deep-groove ball bearings for the 2D model, each value with its source.

Every entry gives the radial-plane geometry the model needs (ball count Z, ball diameter D,
pitch diameter d_m) with the boundary dimensions (bore d, outside diameter D_o, width B), the
basic load ratings C_r and C_0r, the reference and limiting speeds and the bearing mass.
:func:`catalogue_bearing` turns an entry into a :class:`~signatelec.config.bearing.Bearing`:

- raceway radii at the bottom of the grooves, at zero radial clearance (the seed's table 1
  convention, seed eq. 14): ``R_in = (d_m - D) / 2`` and ``R_out = (d_m + D) / 2``;
- groove curvature radii ``f_i D`` and ``f_o D``. Manufacturers do not publish them; the
  entries use ``f_i = 0.52`` and ``f_o = 0.53``, the conformities on which the ISO 281 rating
  formula is based (ISO 281:2007, 6.1.1: groove radii not above 0.52 D and 0.53 D);
- the cage: the seed models it as one small polyamide ball between each pair of balls, on the
  pitch circle (seed 2.2). A cage ball at mid-angle between two balls is ``2 r_p sin(pi / 2Z)``
  from each ball centre, which leaves a gap ``g = 2 r_p sin(pi / 2Z) - R_b`` for its radius. The
  cage ball radius is ``CAGE_FILL g`` with ``CAGE_FILL = 0.995``, the share the seed's own
  model fills (table 1: a 1.00 mm cage ball in a 1.0045 mm gap, 99.5 %). The remaining 0.5 %
  (10-26 um for these sizes) keeps the balls spaced without clamping them. A looser fill is not
  a model of a real cage's pocket clearance: measured with 10 % play, the ball set and cage balls
  oscillate after the spin-up, lightly damped (period ~6 ball passes, cage speed +-0.7 % about
  the kinematic one), and the steady mean resistance and largest ball load stray 1-5 % from the
  quasi-static tier (evenly spaced balls); at 99.5 % they stay within 1 % (the operating map,
  ``signatelec.studies.operating_map``). It is capped at ``CAGE_FILL R_b`` so that the cage
  boundaries (``r_p -+ R_c``) stay between the races;
- the inner ring mass from the ring's geometry, the seed's rule (table 1 and section 2.2.2): a
  steel annulus from the bore to the inner raceway radius, of the bearing's width. It leaves out
  the shoulders above the groove bottom; for the entries below, rings and balls so computed weigh
  about 3/4 of the catalogue mass, which also counts the shoulders, the cage and the seals.

The ``seed`` entry is the seed's 2D model of an SKF 6208 (table 1), ``Bearing()`` itself: its
cage ball (1.00 mm, filling 99.5 % of its gap) and inner ring mass are the seed's own, re-derived
by the rules above only if its ball set is overridden.

Sources
-------
Each value checked against its source, with the agreement and what could not be found, is listed in
docs/catalogue_sources.md.

[CWRU] Case Western Reserve University Bearing Data Center, bearing information,
    https://engineering.case.edu/bearingdatacenter/bearing-information: drive-end bearing SKF
    6205-2RS JEM (0.9843 x 2.0472 x 0.5906 in, 0.3126 in balls, 1.537 in pitch) and fan-end
    bearing SKF 6203-2RS JEM (0.2656 in, 1.122 in). The page gives no ball count; its defect
    multipliers (BPFO 3.5848 and 3.0530) give 9 and 8 balls.
[KAt] C. Lessmeier, J. K. Kimotho, D. Zimmer, W. Sextro, "Condition monitoring of bearing damage
    in electromechanical drive systems by using motor current signals of electric motors: a
    benchmark data set for data-driven classification", PHM Society European Conference, 2016
    (Paderborn University KAt data set): type 6203, 8 balls of 6.75 mm on a 28.55 mm pitch (as
    quoted in code using the data set; the paper itself not checked).
[SKF] SKF, *Rolling bearings*, PUB BU/P1 17000/1 EN, 2018, product table 1.1 (single row deep
    groove ball bearings): C_r, C_0r, reference and limiting speeds, mass; rows 6203 and 6205
    checked. For 6206 and 6305, C_r and C_0r agree with SKF's capped-bearing table 1.2 (6206-2Z,
    6305-2Z); the other SKF values are not yet checked.
[SKF-min] SKF, *Rolling bearings*, PUB BU/P1 17000/1 EN, 2018, deep groove ball bearings,
    "Loads", requisite minimum load: F_rm = k_r (nu n / 1000)^(2/3) (d_m / 100)^2 in kN, with
    nu the operating kinematic viscosity (mm^2/s), n the speed (r/min), d_m = (d + D) / 2 (mm)
    and the minimum load factor k_r of the product table: 0.025 for the 62 series, 0.03 for the
    63 series.
[NSK] the seed, section 2.2.2: NSK gives C_r = 29 100 N for the 6208 (and SKF 32 500 N).
[ISO 15] ISO 15:2017, boundary dimensions d x D_o x B of the 62 and 63 series.
Ball sizes given in inches are the standard inch balls the bearings carry (ISO 3290).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from numbers import Integral, Real
from typing import TYPE_CHECKING

from signatelec.config.bearing import STEEL, Bearing, BearingError, Material, seed_bearing
from signatelec.physics.kinematics import characteristic_orders

if TYPE_CHECKING:  # imported where the table is made: a scene needs no pandas
    import pandas as pd

INCH_M = 25.4e-3
#: Share of the gap between neighbouring balls that a cage ball fills: the seed's 99.5 % (module
#: notes).
CAGE_FILL = 0.995
#: Groove conformities r_groove / D used where the manufacturer publishes none (ISO 281, 6.1.1).
INNER_CONFORMITY = 0.52
OUTER_CONFORMITY = 0.53


class CatalogueError(BearingError):
    """An unknown designation or override; the message names it and what is allowed."""


@dataclass(frozen=True)
class CatalogueEntry:
    """One bearing of the catalogue: published values in SI units, and where each comes from."""

    designation: str
    name: str
    n_balls: int
    ball_diameter_m: float
    pitch_diameter_m: float
    bore_diameter_m: float
    outside_diameter_m: float
    width_m: float
    dynamic_load_rating_n: float
    static_load_rating_n: float
    reference_speed_rpm: float
    limiting_speed_rpm: float
    mass_kg: float
    geometry_source: str
    ratings_source: str
    inner_conformity: float = INNER_CONFORMITY
    outer_conformity: float = OUTER_CONFORMITY

    @property
    def inner_race_radius_m(self) -> float:
        """Inner raceway radius at the groove bottom, zero clearance: (d_m - D) / 2."""
        return 0.5 * (self.pitch_diameter_m - self.ball_diameter_m)

    @property
    def outer_race_radius_m(self) -> float:
        """Outer raceway radius at the groove bottom, zero clearance: (d_m + D) / 2."""
        return 0.5 * (self.pitch_diameter_m + self.ball_diameter_m)


def cage_ball_radius_m(n_balls: int, ball_radius_m: float, pitch_radius_m: float) -> float:
    """Radius of the seed-style cage ball sized to the gap between neighbouring balls.

    ``CAGE_FILL (2 r_p sin(pi / 2Z) - R_b)``, at most ``CAGE_FILL R_b`` (module notes).

    Raises
    ------
    BearingError
        If no gap is left: the balls touch or overlap on the pitch circle.
    """
    gap_m = 2.0 * pitch_radius_m * math.sin(math.pi / (2 * n_balls)) - ball_radius_m
    if not gap_m > 0.0:
        raise BearingError(
            f"bearing.n_balls = {n_balls!r}: {n_balls} balls of radius {ball_radius_m:g} m "
            f"leave no room for a cage on the pitch circle of radius {pitch_radius_m:g} m "
            f"(need 2 r_p sin(pi/2Z) > R_b)"
        )
    return CAGE_FILL * min(gap_m, ball_radius_m)


def inner_ring_mass_kg(inner_race_radius_m: float, bore_diameter_m: float, width_m: float) -> float:
    """Steel annulus from the bore to the inner raceway radius, of the bearing width (seed rule)."""
    return (
        STEEL.density_kg_m3
        * math.pi
        * (inner_race_radius_m**2 - (0.5 * bore_diameter_m) ** 2)
        * width_m
    )


_SEED = seed_bearing()

_ENTRIES = (
    CatalogueEntry(
        designation="seed",
        name=_SEED.name,
        n_balls=_SEED.n_balls,
        ball_diameter_m=2.0 * _SEED.ball_radius_m,
        pitch_diameter_m=2.0 * _SEED.pitch_radius_m,
        bore_diameter_m=40e-3,
        outside_diameter_m=80e-3,
        width_m=18e-3,
        dynamic_load_rating_n=_SEED.dynamic_load_rating_n,
        static_load_rating_n=math.nan,
        reference_speed_rpm=math.nan,
        limiting_speed_rpm=math.nan,
        mass_kg=math.nan,
        geometry_source=(
            "seed table 1 (2D model: 13 balls of 12.6 mm); d x D_o x B of a 6208 [ISO 15]"
        ),
        ratings_source="[NSK] via the seed 2.2.2; the seed gives no C_0r, speeds or mass",
        inner_conformity=_SEED.inner_groove_radius_m / (2.0 * _SEED.ball_radius_m),
        outer_conformity=_SEED.outer_groove_radius_m / (2.0 * _SEED.ball_radius_m),
    ),
    CatalogueEntry(
        designation="6203",
        name="SKF 6203 (CWRU fan-end geometry)",
        n_balls=8,
        ball_diameter_m=0.2656 * INCH_M,
        pitch_diameter_m=1.122 * INCH_M,
        bore_diameter_m=17e-3,
        outside_diameter_m=40e-3,
        width_m=12e-3,
        dynamic_load_rating_n=9950.0,
        static_load_rating_n=4750.0,
        reference_speed_rpm=38000.0,
        limiting_speed_rpm=24000.0,
        mass_kg=0.065,
        geometry_source="[CWRU] fan end, SKF 6203-2RS JEM; [KAt] 6203 agrees within 0.2 %",
        ratings_source="[SKF]",
    ),
    CatalogueEntry(
        designation="6204",
        name="SKF 6204",
        n_balls=8,
        ball_diameter_m=5 / 16 * INCH_M,
        pitch_diameter_m=33.5e-3,
        bore_diameter_m=20e-3,
        outside_diameter_m=47e-3,
        width_m=14e-3,
        dynamic_load_rating_n=13500.0,
        static_load_rating_n=6550.0,
        reference_speed_rpm=32000.0,
        limiting_speed_rpm=20000.0,
        mass_kg=0.11,
        geometry_source=(
            "8 balls of 5/16 in; pitch derived as (d + D_o) / 2 [ISO 15]; ISO 281 with this "
            "ball set gives 12.8 kN, the NSK rating of the 6204"
        ),
        ratings_source="[SKF]",
    ),
    CatalogueEntry(
        designation="6205",
        name="SKF 6205 (CWRU drive-end geometry)",
        n_balls=9,
        ball_diameter_m=0.3126 * INCH_M,
        pitch_diameter_m=1.537 * INCH_M,
        bore_diameter_m=25e-3,
        outside_diameter_m=52e-3,
        width_m=15e-3,
        dynamic_load_rating_n=14800.0,
        static_load_rating_n=7800.0,
        reference_speed_rpm=28000.0,
        limiting_speed_rpm=18000.0,
        mass_kg=0.13,
        geometry_source=(
            "[CWRU] drive end, SKF 6205-2RS JEM (pitch 39.04 mm, 1.4 % above (d + D_o) / 2)"
        ),
        ratings_source="[SKF]",
    ),
    CatalogueEntry(
        designation="6206",
        name="SKF 6206",
        n_balls=9,
        ball_diameter_m=3 / 8 * INCH_M,
        pitch_diameter_m=46e-3,
        bore_diameter_m=30e-3,
        outside_diameter_m=62e-3,
        width_m=16e-3,
        dynamic_load_rating_n=20300.0,
        static_load_rating_n=11200.0,
        reference_speed_rpm=24000.0,
        limiting_speed_rpm=15000.0,
        mass_kg=0.20,
        geometry_source=(
            "9 balls of 3/8 in; pitch derived as (d + D_o) / 2 [ISO 15]; ISO 281 with this "
            "ball set gives 19.5 kN, the NSK rating of the 6206"
        ),
        ratings_source="[SKF]",
    ),
    CatalogueEntry(
        designation="6208",
        name="SKF 6208",
        n_balls=9,
        ball_diameter_m=0.5 * INCH_M,
        pitch_diameter_m=60e-3,
        bore_diameter_m=40e-3,
        outside_diameter_m=80e-3,
        width_m=18e-3,
        dynamic_load_rating_n=32500.0,
        static_load_rating_n=19000.0,
        reference_speed_rpm=18000.0,
        limiting_speed_rpm=11000.0,
        mass_kg=0.37,
        geometry_source=(
            "9 balls of 1/2 in; pitch derived as (d + D_o) / 2 [ISO 15], raceway radii "
            "23.65 / 36.35 mm; ISO 281 with this ball set gives 32.6 kN"
        ),
        ratings_source="[SKF] (the seed quotes SKF's 32 500 N)",
    ),
    CatalogueEntry(
        designation="6305",
        name="SKF 6305",
        n_balls=7,
        ball_diameter_m=11.5e-3,
        pitch_diameter_m=43.5e-3,
        bore_diameter_m=25e-3,
        outside_diameter_m=62e-3,
        width_m=17e-3,
        dynamic_load_rating_n=23400.0,
        static_load_rating_n=11600.0,
        reference_speed_rpm=20000.0,
        limiting_speed_rpm=13000.0,
        mass_kg=0.23,
        geometry_source=(
            "estimated, not published: 7 balls of 11.5 mm, the set whose ISO 281 rating "
            "(22.4 kN) stands to SKF's C_r as for the other SKF entries; pitch (d + D_o) / 2"
        ),
        ratings_source="[SKF]",
    ),
    CatalogueEntry(
        designation="6308",
        name="SKF 6308",
        n_balls=8,
        ball_diameter_m=19 / 32 * INCH_M,
        pitch_diameter_m=65e-3,
        bore_diameter_m=40e-3,
        outside_diameter_m=90e-3,
        width_m=23e-3,
        dynamic_load_rating_n=42300.0,
        static_load_rating_n=24000.0,
        reference_speed_rpm=17000.0,
        limiting_speed_rpm=11000.0,
        mass_kg=0.63,
        geometry_source=(
            "8 balls of 19/32 in; pitch derived as (d + D_o) / 2 [ISO 15]; ISO 281 with this "
            "ball set gives 40.7 kN"
        ),
        ratings_source="[SKF]",
    ),
)

CATALOGUE: dict[str, CatalogueEntry] = {e.designation: e for e in _ENTRIES}
DEFAULT_DESIGNATION = "seed"

# Bearing fields the others follow: overriding one re-derives the fields of _derived_fields
# (unless they are overridden too), so that an override keeps the geometry consistent.
_PRIMARY = ("n_balls", "ball_radius_m", "inner_race_radius_m")


def catalogue_entry(designation: str) -> CatalogueEntry:
    """The entry of ``designation`` (case and surrounding spaces ignored)."""
    key = str(designation).strip().lower()
    if key not in CATALOGUE:
        raise CatalogueError(
            f"bearing.designation = {designation!r}: unknown bearing; known: {', '.join(CATALOGUE)}"
        )
    return CATALOGUE[key]


#: The real bearing the seed's 2D model stands for (seed section 2.2.2: an SKF 6208).
SEED_REAL_BEARING = "6208"


def rated_entry(designation: str) -> CatalogueEntry:
    """The entry whose series, bore and speeds a designation runs at: its own, or for the
    seed's 2D model (which gives no speeds) the 6208's."""
    key = str(designation).strip().lower()
    return catalogue_entry(SEED_REAL_BEARING if key == "seed" else key)


def limiting_speed_rad_s(designation: str) -> float:
    """The limiting speed ``designation`` runs at (:func:`rated_entry`: the seed's 2D model at
    the 6208's), rad/s."""
    return rated_entry(designation).limiting_speed_rpm * 2.0 * math.pi / 60.0


def designation_of(bearing: Bearing) -> str | None:
    """The designation of the catalogue entry ``bearing`` was made from (found by its name),
    None for a bearing the catalogue does not hold."""
    return next((e.designation for e in _ENTRIES if e.name == bearing.name), None)


def _derived_fields(entry: CatalogueEntry, n_balls: int, ball_radius_m: float, r_in_m: float):
    """The fields that follow from the ball set and the inner raceway radius."""
    diameter_m = 2.0 * ball_radius_m
    return {
        "outer_race_radius_m": r_in_m + diameter_m,
        "inner_groove_radius_m": entry.inner_conformity * diameter_m,
        "outer_groove_radius_m": entry.outer_conformity * diameter_m,
        "cage_ball_radius_m": cage_ball_radius_m(n_balls, ball_radius_m, r_in_m + ball_radius_m),
        "inner_ring_mass_kg": inner_ring_mass_kg(r_in_m, entry.bore_diameter_m, entry.width_m),
    }


def _entry_fields(entry: CatalogueEntry) -> dict:
    """All Bearing fields of an entry, before overrides."""
    if entry.designation == DEFAULT_DESIGNATION:
        return _SEED.to_dict()
    ball_radius_m = 0.5 * entry.ball_diameter_m
    return {
        **_SEED.to_dict(),  # the seed's materials, friction and conductivity
        "name": entry.name,
        "n_balls": entry.n_balls,
        "ball_radius_m": ball_radius_m,
        "inner_race_radius_m": entry.inner_race_radius_m,
        "dynamic_load_rating_n": entry.dynamic_load_rating_n,
        **_derived_fields(entry, entry.n_balls, ball_radius_m, entry.inner_race_radius_m),
    }


def _check_primary(overrides: dict) -> None:
    """The overridden fields the others are derived from must be usable numbers."""
    n = overrides.get("n_balls", 3)
    if isinstance(n, bool) or not isinstance(n, Integral) or n < 3:
        raise BearingError(f"bearing.n_balls = {n!r}: must be an integer >= 3")
    for key in ("ball_radius_m", "inner_race_radius_m"):
        v = overrides.get(key, 1.0)
        if isinstance(v, bool) or not isinstance(v, Real) or not math.isfinite(v) or v <= 0:
            raise BearingError(f"bearing.{key} = {v!r}: must be a finite number > 0")


def catalogue_bearing(designation: str = DEFAULT_DESIGNATION, **overrides) -> Bearing:
    """The :class:`Bearing` of a catalogue entry, any field overridable.

    Overriding ``n_balls``, ``ball_radius_m`` or ``inner_race_radius_m`` re-derives the outer
    raceway radius (zero clearance), the groove radii (the entry's conformities), the cage ball
    and the inner ring mass, unless those are overridden as well. Materials may be given by name
    (``"steel"``, ``"polyamide"``) as in a scene file.

    Raises
    ------
    CatalogueError
        Unknown designation or override key (one line naming it and what is allowed).
    BearingError
        The overridden bearing is not physical (the message names the field).
    """
    entry = catalogue_entry(designation)
    values = _entry_fields(entry)
    unknown = sorted(set(overrides) - set(values))
    if unknown:
        key = unknown[0]
        raise CatalogueError(
            f"bearing.{key} = {overrides[key]!r}: unknown key; allowed: {', '.join(sorted(values))}"
        )
    if any(k in overrides for k in _PRIMARY):
        _check_primary(overrides)
        primary = {k: overrides.get(k, values[k]) for k in _PRIMARY}
        derived = _derived_fields(
            entry, primary["n_balls"], primary["ball_radius_m"], primary["inner_race_radius_m"]
        )
        values.update({k: v for k, v in derived.items() if k not in overrides})
    values.update({k: asdict(v) if isinstance(v, Material) else v for k, v in overrides.items()})
    return Bearing.from_dict(values)


#: Minimum load factor k_r of the deep-groove ball bearings by dimension series [SKF-min].
MINIMUM_LOAD_FACTOR = {"62": 0.025, "63": 0.03}


def minimum_load_n(designation: str, viscosity_mm2_s: float, omega_rad_s: float) -> float:
    """The radial load below which the balls skid instead of rolling, N [SKF-min].

    ``F_rm = k_r (nu n / 1000)^(2/3) (d_m / 100)^2`` kN, n the inner-ring speed in r/min, nu the
    lubricant's kinematic viscosity at the operating temperature in mm^2/s. Below it the ball
    set's inertia and the lubricant's drag need more traction than the load gives (the seed's
    bearing: a 6208's, whose 2D model it is).
    """
    entry = rated_entry(designation)
    factor = MINIMUM_LOAD_FACTOR.get(entry.designation[:2])
    if factor is None:
        raise CatalogueError(f"bearing {designation!r}: no minimum load factor for its series")
    speed_rpm = abs(omega_rad_s) * 60.0 / (2.0 * math.pi)
    mean_diameter_mm = 0.5e3 * (entry.bore_diameter_m + entry.outside_diameter_m)
    return (
        1e3
        * factor
        * (viscosity_mm2_s * speed_rpm / 1e3) ** (2.0 / 3.0)
        * (mean_diameter_mm / 100.0) ** 2
    )


def list_bearings(contact_angle_rad: float = 0.0) -> pd.DataFrame:
    """The catalogue as a table, one row per entry, in SI units (speeds in r/min as published,
    the limiting speed also in rad/s).

    Besides the published values, each row gives the raceway radii the model uses and the
    characteristic defect frequencies as orders of the shaft speed (cage FTF, BPFO, BPFI, BSF;
    :func:`~signatelec.physics.kinematics.characteristic_orders`).
    """
    rows = []
    for entry in _ENTRIES:
        row = asdict(entry)
        bearing = catalogue_bearing(entry.designation)
        row["inner_race_radius_m"] = bearing.inner_race_radius_m
        row["outer_race_radius_m"] = bearing.outer_race_radius_m
        row["cage_ball_radius_m"] = bearing.cage_ball_radius_m
        row["inner_ring_mass_kg"] = bearing.inner_ring_mass_kg
        row["limiting_speed_rad_s"] = entry.limiting_speed_rpm * 2.0 * math.pi / 60.0
        orders = characteristic_orders(bearing, contact_angle_rad)
        row.update({f"{k}_order": v for k, v in orders.items()})
        rows.append(row)
    import pandas as pd

    return pd.DataFrame(rows).set_index("designation")
