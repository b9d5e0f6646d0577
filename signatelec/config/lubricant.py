"""The oil and the surfaces of a lubricated bearing: named oils with sources, the scene's section.

``[lubricant]`` in a scene names an oil of :data:`OILS` and its temperature; any property of
the oil may be overridden (0 keeps the oil's value). The composite roughness of balls and races
and the meniscus gap of the film's outside zone are properties of the scene too.

Sources of the oils' data
-------------------------
- Kinematic viscosity at 40 C: the ISO VG midpoint (ISO 3448:1992); at 100 C: the value a
  viscosity index of 100 (mineral) or ~145 (PAO) gives (ASTM D2270 tables).
- Density at 15 C: 870-880 kg/m^3 for paraffinic mineral oils, ~835 kg/m^3 for PAO (supplier
  data sheets); thermal expansion 6.4e-4 1/K (ASTM D1250 order for lubricating oils).
- Pressure-viscosity coefficient: 2.2e-8 1/Pa for mineral oils (Hamrock 1994, Fundamentals of
  Fluid Film Lubrication, ch. 4 and its worked examples; Harris and Kotzalas 2007, Essential
  Concepts of Bearing Technology, table 4.x: 1.5-2.5e-8); 1.6e-8 1/Pa for PAO (Gold, Schmidt,
  Dicke, Loos, Assmann, Tribol. Trans. 2001: 1.3-1.8e-8 at 40 C). Taken independent of
  temperature here.
- Relative permittivity: 2.2 mineral, 2.1 PAO (Jablonka, Glovnea, Bongaerts 2012, J. Phys. D 45
  385301: 2.1-2.3 for base oils).
- Resistivity: 1e12 ohm m mineral, 1e13 ohm m PAO (order of IEC 60247 measurements of
  hydrocarbon oils; the film's leakage is negligible beside its capacitance at any of them).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from signatelec.physics.ehl import composite_roughness_m, walther_kinematic_viscosity_mm2_s


@dataclass(frozen=True)
class Oil:
    """A named oil (see the module docstring for the sources)."""

    name: str
    viscosity_40c_mm2_s: float
    viscosity_100c_mm2_s: float
    density_kg_m3: float  # at 15 C
    pressure_viscosity_1_pa: float
    relative_permittivity: float
    resistivity_ohm_m: float
    source: str


OILS: dict[str, Oil] = {
    o.name: o
    for o in (
        Oil("ISO VG 32", 32.0, 5.44, 870.0, 2.2e-8, 2.2, 1e12, "mineral, VI 100"),
        Oil("ISO VG 68", 68.0, 8.73, 875.0, 2.2e-8, 2.2, 1e12, "mineral, VI 100"),
        Oil("ISO VG 100", 100.0, 11.4, 880.0, 2.2e-8, 2.2, 1e12, "mineral, VI 100"),
        Oil("PAO 68", 68.0, 10.5, 835.0, 1.6e-8, 2.1, 1e13, "synthetic polyalphaolefin, VI 145"),
    )
}
#: Thermal expansion of the oils' density, 1/K.
EXPANSION_1_K = 6.4e-4
#: Properties of :class:`Oil` a scene may override.
OVERRIDABLE = tuple(
    f for f in Oil.__dataclass_fields__ if f not in ("name", "source")
)  # fmt: skip


@dataclass(frozen=True)
class Lubricant:
    """``[lubricant]``: the oil, its temperature, the surfaces; 0 keeps the oil's value."""

    oil: str = "ISO VG 68"
    temperature_c: float = 40.0
    viscosity_40c_mm2_s: float = 0.0
    viscosity_100c_mm2_s: float = 0.0
    density_kg_m3: float = 0.0
    pressure_viscosity_1_pa: float = 0.0
    relative_permittivity: float = 0.0
    resistivity_ohm_m: float = 0.0
    #: rms roughness Rq of the balls and of the raceways, m (Hamrock 1994's deep-groove ball
    #: bearing example: 0.0175 and 0.0625 um).
    ball_roughness_m: float = 0.0175e-6
    race_roughness_m: float = 0.0625e-6
    #: Gap at which the inlet meniscus bounds the film outside the Hertz zone, m: a fully
    #: flooded contact with the oil reaching ~50 um of separation (~0.7 mm from the contact
    #: centre of the seed's 6208; Jablonka et al. 2018 bound theirs at a similar distance).
    #: The outside-zone capacitance grows as its logarithm only.
    meniscus_gap_m: float = 50e-6

    def oil_data(self) -> Oil:
        """The named oil with this section's overrides."""
        oil = OILS[self.oil]
        return replace(oil, **{f: getattr(self, f) or getattr(oil, f) for f in OVERRIDABLE})

    def kinematic_viscosity_mm2_s(self) -> float:
        """The oil's kinematic viscosity at ``temperature_c`` (Walther, ASTM D341), mm^2/s."""
        oil = self.oil_data()
        return float(
            walther_kinematic_viscosity_mm2_s(
                self.temperature_c, oil.viscosity_40c_mm2_s, oil.viscosity_100c_mm2_s
            )
        )

    def resolved(self) -> LubricantProperties:
        """The oil's data with this section's overrides, at ``temperature_c``."""
        oil = self.oil_data()
        nu_mm2_s = self.kinematic_viscosity_mm2_s()
        density = oil.density_kg_m3 * (1.0 - EXPANSION_1_K * (self.temperature_c - 15.0))
        return LubricantProperties(
            oil=oil,
            temperature_c=self.temperature_c,
            viscosity_pa_s=nu_mm2_s * 1e-6 * density,
            pressure_viscosity_1_pa=oil.pressure_viscosity_1_pa,
            relative_permittivity=oil.relative_permittivity,
            resistivity_ohm_m=oil.resistivity_ohm_m,
            roughness_m=composite_roughness_m(self.ball_roughness_m, self.race_roughness_m),
            meniscus_gap_m=self.meniscus_gap_m,
        )


@dataclass(frozen=True)
class LubricantProperties:
    """What the lubricated-contact model needs, resolved at the oil's temperature."""

    oil: Oil
    temperature_c: float
    viscosity_pa_s: float
    pressure_viscosity_1_pa: float
    relative_permittivity: float
    resistivity_ohm_m: float
    roughness_m: float  # composite sigma
    meniscus_gap_m: float
