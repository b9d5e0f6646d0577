"""Bearing geometry and materials as data, and the equivalent contact quantities.

The default bearing is the 2D SKF 6208 of the seed paper (Machado, Guessasma, Bellenger,
*Modelling of ball bearing loading by DEM for electromechanical coupling*), table 1:
13 steel balls, 13 polyamide cage balls. Every quantity is SI and carries its unit in its name.

Contact types (seed table 2) are indexed by the constants ``INNER``, ``OUTER``, ``BALL_CAGE``,
``CAGE_WALL`` and ``BALL_BALL``. The seed's "cage/cage" row (``R_eq = r_i``, ``m* = m_i``: the
quantities of one body against a rigid surface) is read here as a cage ball against one of the two
frictionless cage boundaries; cage balls never touch each other because a rolling ball always
stands between two of them. ``BALL_BALL`` (steel on steel, frictionless) only exists when the cage
effect is off. ``BALL_POCKET`` is a ball in its pocket of the rigid cage (``effects.cage =
"rigid"``, not in the seed): see :meth:`Bearing.rigid_cage_mass_kg` and :func:`contact_properties`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from functools import cache

from signatelec.config.constraints import BEARING, MATERIAL, Checker

# Contact-type indices, shared by the kernels, the stability estimate and the tests.
INNER, OUTER, BALL_CAGE, CAGE_WALL, BALL_BALL, BALL_POCKET = range(6)
CONTACT_TYPES = ("inner", "outer", "ball_cage", "cage_wall", "ball_ball", "ball_pocket")

STANDARD_GRAVITY_M_S2 = 9.80665


class BearingError(ValueError):
    """A bearing description that is not physical; the message names the field."""


@dataclass(frozen=True)
class Material:
    """An isotropic elastic material."""

    name: str
    youngs_modulus_pa: float
    poisson: float
    density_kg_m3: float

    @property
    def shear_modulus_pa(self) -> float:
        """G = E / (2 (1 + nu)) (seed, after eq. 7)."""
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson))

    @property
    def plane_strain_modulus_pa(self) -> float:
        """E_eq = E / (1 - nu^2) (seed section 3, used by eq. 18)."""
        return self.youngs_modulus_pa / (1.0 - self.poisson**2)


#: Bearing steel of the seed (section 2.2): E_b = 203 GPa, nu_b = 0.3.
STEEL = Material("steel", 203e9, 0.3, 7850.0)
#: Polyamide of the cage balls (section 2.2): E_c = 3 GPa, nu_c = 0.3 (PA66 density).
POLYAMIDE = Material("polyamide", 3e9, 0.3, 1140.0)

#: Glass-fibre reinforced polyamide 66 (25 % glass), the usual moulded cage material (SKF's
#: "TN9" cages): E = 8 GPa, density 1320 kg/m^3 (dry, manufacturers' data sheets of PA66-GF25,
#: e.g. BASF Ultramid A3EG5), nu = 0.35 (typical of glass-filled polyamides).
PA66_GF25 = Material("PA66-GF25", 8.0e9, 0.35, 1320.0)

MATERIALS = {m.name: m for m in (STEEL, POLYAMIDE, PA66_GF25)}
#: The Bearing fields that hold a Material.
MATERIAL_FIELDS = ("ball_material", "cage_material", "rigid_cage_material")


@dataclass(frozen=True)
class Bearing:
    """Geometry and materials of a radial ball bearing, 2D model of the seed (section 2.2).

    ``outer_race_radius_m`` is the outer race radius at zero clearance (table 1 gives it for
    Delta_r = 0), so it must equal ``inner_race_radius_m + 2 * ball_radius_m``; the clearance or
    preload of a scene moves it (eq. 14). Masses are those of 3D spheres (the seed's discrete
    elements are spheres).
    """

    name: str = "SKF 6208 (2D model of the seed, table 1)"
    n_balls: int = 13
    outer_race_radius_m: float = 36.60e-3
    inner_race_radius_m: float = 24.00e-3
    outer_groove_radius_m: float = 6.65e-3
    inner_groove_radius_m: float = 6.55e-3
    ball_radius_m: float = 6.30e-3
    cage_ball_radius_m: float = 1.00e-3
    ball_material: Material = STEEL
    cage_material: Material = POLYAMIDE
    #: Coulomb coefficient on ball/raceway contacts; all other contacts are frictionless (2.2).
    friction_coefficient: float = 0.15
    #: Basic dynamic load rating C_r (NSK 29100 N; SKF gives 32500 N), section 2.2.2.
    dynamic_load_rating_n: float = 29100.0
    #: Inner ring mass: a steel ring from the bore (d = 40 mm) to the race, width 18 mm.
    inner_ring_mass_kg: float = field(
        default=STEEL.density_kg_m3 * math.pi * (24.0e-3**2 - 20.0e-3**2) * 18.0e-3
    )
    #: Electrical conductivity gamma of the ball steel, eq. 16.
    electrical_conductivity_s_m: float = 5.8e7
    #: Rigid cage (``effects.cage = "rigid"``): its material and the diametral clearance of a
    #: ball in its spherical pocket, 2 (R_pocket - R_b). 0.010 in = 0.254 mm: the smallest
    #: diametral pocket clearance of ball retainers of the larger (non-instrument) bearings, whose
    #: miniature and instrument bearings go down to 0.0035 in (retainer terminology of cage
    #: makers, e.g. "Ball pocket" in compraco.com.br, "Gaiolas para rolamentos de esferas"); the
    #: order of the play the catalogue's cage-ball sizing leaves (signatelec.config.catalogue).
    rigid_cage_material: Material = PA66_GF25
    pocket_clearance_m: float = 0.254e-3

    def __post_init__(self) -> None:
        validate_bearing(self)

    # --- derived geometry -------------------------------------------------------------
    @property
    def pitch_radius_m(self) -> float:
        return self.inner_race_radius_m + self.ball_radius_m

    @property
    def ball_volume_m3(self) -> float:
        return 4.0 / 3.0 * math.pi * self.ball_radius_m**3

    @property
    def ball_mass_kg(self) -> float:
        return self.ball_material.density_kg_m3 * self.ball_volume_m3

    @property
    def ball_inertia_kg_m2(self) -> float:
        """Moment of inertia of a solid sphere, 2/5 m R^2."""
        return 0.4 * self.ball_mass_kg * self.ball_radius_m**2

    @property
    def cage_ball_mass_kg(self) -> float:
        return self.cage_material.density_kg_m3 * 4.0 / 3.0 * math.pi * self.cage_ball_radius_m**3

    # --- rigid cage (effects.cage = "rigid") -------------------------------------------
    # A ring of rectangular section centred on the pitch circle: axial width the ball diameter
    # 2 R_b, radial height R_b (between the races, which are R_b from the pitch circle), with Z
    # spherical pockets of radius R_p = R_b + pocket_clearance_m / 2 cut through it. A pocket
    # removes the part of its sphere inside the radial slab |r - r_p| <= h/2,
    # pi (R_p^2 h - h^3 / 12) (the sliver of pocket sphere beyond the ring's faces, 0.1 mm,
    # is not subtracted twice: ignored). For the seed's 6208: 7.0 g in PA66-GF25.
    @property
    def pocket_radius_m(self) -> float:
        return self.ball_radius_m + 0.5 * self.pocket_clearance_m

    def _rigid_cage_parts(self) -> tuple[float, float, float, float]:
        """(ring mass before the pockets, mass of one pocket, inner and outer radius)."""
        h = self.ball_radius_m
        r_i, r_o = self.pitch_radius_m - 0.5 * h, self.pitch_radius_m + 0.5 * h
        rho = self.rigid_cage_material.density_kg_m3
        ring = rho * math.pi * (r_o**2 - r_i**2) * 2.0 * self.ball_radius_m
        pocket = rho * math.pi * (self.pocket_radius_m**2 * h - h**3 / 12.0)
        return ring, pocket, r_i, r_o

    @property
    def rigid_cage_mass_kg(self) -> float:
        ring, pocket, _, _ = self._rigid_cage_parts()
        return ring - self.n_balls * pocket

    @property
    def rigid_cage_inertia_kg_m2(self) -> float:
        """Polar moment about the bearing axis: the annulus, m (r_o^2 + r_i^2) / 2, less the
        pockets taken as masses at the pitch radius."""
        ring, pocket, r_i, r_o = self._rigid_cage_parts()
        return 0.5 * ring * (r_o**2 + r_i**2) - self.n_balls * pocket * self.pitch_radius_m**2

    def cage_speed_rad_s(self, omega_rad_s: float) -> float:
        """Kinematic cage (ball orbit) speed, omega R_inn / (R_inn + R_out), outer ring fixed."""
        return (
            omega_rad_s
            * self.inner_race_radius_m
            / (self.inner_race_radius_m + self.outer_race_radius_m)
        )

    def ball_spin_rad_s(self, omega_rad_s: float) -> float:
        """Kinematic ball spin about its own centre (negative: opposite to the inner ring)."""
        return -self.cage_speed_rad_s(omega_rad_s) * self.pitch_radius_m / self.ball_radius_m

    def ball_pass_frequency_hz(self, omega_rad_s: float) -> float:
        """Ball-pass frequency over a fixed outer-race point, Z * cage speed / 2 pi."""
        return self.n_balls * self.cage_speed_rad_s(omega_rad_s) / (2.0 * math.pi)

    # --- serialisation --------------------------------------------------------------
    def to_dict(self) -> dict:
        d = asdict(self)
        for key in MATERIAL_FIELDS:
            material = getattr(self, key)
            # a catalogue material by its name; any other (e.g. a mass-scaled cage, see
            # signatelec.engines.fidelity) as its full table, so that from_dict gives it back
            if MATERIALS.get(material.name) == material:
                d[key] = material.name
        return d

    @classmethod
    def from_dict(cls, data: dict, section: str = "bearing") -> Bearing:
        known = {f.name for f in fields(cls)}
        kwargs = {}
        for key, value in data.items():
            if key not in known:
                raise BearingError(
                    f"{section}.{key} = {value!r}: unknown key; allowed: {', '.join(sorted(known))}"
                )
            if key in MATERIAL_FIELDS:
                if isinstance(value, dict):
                    value = _material_from_dict(value, f"{section}.{key}")
                elif isinstance(value, str) and value in MATERIALS:
                    value = MATERIALS[value]
                else:
                    raise BearingError(
                        f"{section}.{key} = {value!r}: unknown material; allowed: "
                        f"{', '.join(MATERIALS)} or a table with name, youngs_modulus_pa, "
                        "poisson, density_kg_m3"
                    )
            kwargs[key] = value
        return cls(**kwargs)

    def with_(self, **changes) -> Bearing:
        return replace(self, **changes)


def _material_from_dict(data: dict, where: str) -> Material:
    """A :class:`Material` from a TOML table; unknown or missing keys raise BearingError."""
    names = [f.name for f in fields(Material)]
    for key, value in data.items():
        if key not in names:
            raise BearingError(
                f"{where}.{key} = {value!r}: unknown key; allowed: {', '.join(names)}"
            )
    missing = [n for n in names if n not in data]
    if missing:
        raise BearingError(
            f"{where} = {data!r}: missing {', '.join(missing)}; a material table needs "
            f"{', '.join(names)}"
        )
    return Material(**data)


def validate_bearing(b: Bearing, section: str = "bearing") -> None:
    """Raise :class:`BearingError` naming the first non-physical field: the rows of
    :data:`signatelec.config.constraints.BEARING` and, per material, of ``MATERIAL``."""

    def balls_fit() -> bool:
        # balls and cage balls alternate on the pitch circle: neighbours 2 pi / (2 Z) apart
        chord = 2.0 * b.pitch_radius_m * math.sin(math.pi / (2 * b.n_balls))
        return chord >= b.ball_radius_m + b.cage_ball_radius_m

    def zero_clearance_outer_m() -> float:
        return b.inner_race_radius_m + 2.0 * b.ball_radius_m

    # limits are evaluated when a row needs them, after the rows that check their inputs
    check = Checker(
        BearingError,
        limits={
            "ball_radius_m": lambda: b.ball_radius_m,
            "cage_ball_radius_m": lambda: b.cage_ball_radius_m,
            "pitch_radius_m": lambda: b.pitch_radius_m,
            "zero_clearance_outer_race_radius_m": zero_clearance_outer_m,
            "zero_clearance_geometry": lambda: (
                abs(b.outer_race_radius_m - zero_clearance_outer_m()) <= 1e-9
            ),
            "balls_fit": balls_fit,
        },
    )
    for row in BEARING:
        check.check(row, getattr(b, row.key), f"{section}.{row.key}")
    for mat_key in MATERIAL_FIELDS:
        m = getattr(b, mat_key)
        if not isinstance(m, Material):
            check.fail(
                f"{section}.{mat_key}", m, f"must be one of {', '.join(MATERIALS)} or a Material"
            )
        for row in MATERIAL:
            check.check(row, getattr(m, row.key), f"{section}.{mat_key}.{row.key}")


@cache
def seed_bearing() -> Bearing:
    """The seed's bearing (table 1), ``Bearing()``, built and validated once."""
    return Bearing()


def same_bearing(a: Bearing | None, b: Bearing | None) -> bool:
    """Whether ``a`` and ``b`` are one bearing, None standing for the seed's."""
    return (a or seed_bearing()) == (b or seed_bearing())


# --- equivalent quantities (seed eqs 12-13, table 2) -----------------------------------------


def raceway_radii(bearing: Bearing) -> dict[str, tuple[float, float, float, float]]:
    """Principal radii, equivalent radius and radius ratio of the ball/raceway contacts.

    Returns ``{"inner": (r1, r2, r_eq, alpha), "outer": (...)}`` following seed eq. 12 (inner) and
    eq. 13 (outer): ``r_eq = r1 r2 / (r1 + r2)`` and ``alpha = r2 / r1``.
    """
    rb = bearing.ball_radius_m
    r1_in = 1.0 / (1.0 / rb + 1.0 / bearing.inner_race_radius_m)
    r2_in = 1.0 / (1.0 / rb - 1.0 / bearing.inner_groove_radius_m)
    r1_out = 1.0 / (1.0 / rb - 1.0 / bearing.outer_race_radius_m)
    r2_out = 1.0 / (1.0 / rb - 1.0 / bearing.outer_groove_radius_m)
    return {
        "inner": (r1_in, r2_in, r1_in * r2_in / (r1_in + r2_in), r2_in / r1_in),
        "outer": (r1_out, r2_out, r1_out * r2_out / (r1_out + r2_out), r2_out / r1_out),
    }


@dataclass(frozen=True)
class ContactProperties:
    """Equivalent quantities of one contact type (seed table 2)."""

    name: str
    shear_modulus_pa: float
    poisson: float
    radius_eq_m: float
    reduced_mass_kg: float
    friction_coefficient: float


def contact_properties(bearing: Bearing) -> tuple[ContactProperties, ...]:
    """Table 2 of the seed for every contact type, indexed by ``INNER .. BALL_BALL``, and the
    rigid cage's ball/pocket contact (``BALL_POCKET``)."""
    radii = raceway_radii(bearing)
    gb = bearing.ball_material.shear_modulus_pa
    gc = bearing.cage_material.shear_modulus_pa
    nu_b = bearing.ball_material.poisson
    nu_c = bearing.cage_material.poisson
    mb, mc = bearing.ball_mass_kg, bearing.cage_ball_mass_kg
    rb, rc = bearing.ball_radius_m, bearing.cage_ball_radius_m
    mu = bearing.friction_coefficient
    # Ball in its spherical pocket: conformal Hertz contact, 1/R_eq = 1/R_b - 1/R_p (a concave
    # surface has a negative radius), with the effective modulus of the two materials,
    # 1/E* = (1 - nu_b^2)/E_b + (1 - nu_p^2)/E_p (K. L. Johnson, Contact Mechanics, 1985,
    # section 4.2; not the seed's table-2 averages of G and nu, which would give a polyamide
    # contact nearly steel's stiffness). Hertz holds while the contact radius sqrt(R_eq delta)
    # stays well below R_b: 0.8 mm at 20 N (steady running at 500 rad/s), 2.5 mm at 590 N (the
    # 5 ms spin-up to 3000 rad/s).
    # Written as the (G, nu) pair that physics.contact.hertz_coefficient, 4 G sqrt(R) /
    # (3 (1 - nu)) = 4/3 E* sqrt(R), turns into it: nu the mean, G = E* (1 - nu).
    cage = bearing.rigid_cage_material
    rp = bearing.pocket_radius_m
    e_star = 1.0 / (
        (1.0 - nu_b**2) / bearing.ball_material.youngs_modulus_pa
        + (1.0 - cage.poisson**2) / cage.youngs_modulus_pa
    )
    nu_p = 0.5 * (nu_b + cage.poisson)
    m_cage = bearing.rigid_cage_mass_kg
    return (
        ContactProperties("inner", gb, nu_b, radii["inner"][2], mb, mu),
        ContactProperties("outer", gb, nu_b, radii["outer"][2], mb, mu),
        ContactProperties(
            "ball_cage",
            0.5 * (gb + gc),
            0.5 * (nu_b + nu_c),
            rb * rc / (rb + rc),
            mb * mc / (mb + mc),
            0.0,
        ),
        ContactProperties("cage_wall", gc, nu_c, rc, mc, 0.0),
        ContactProperties("ball_ball", gb, nu_b, 0.5 * rb, 0.5 * mb, 0.0),
        ContactProperties(
            "ball_pocket",
            e_star * (1.0 - nu_p),
            nu_p,
            rb * rp / (rp - rb),
            mb * m_cage / (mb + m_cage),
            0.0,
        ),
    )
