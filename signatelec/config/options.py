"""Every choice of a scene, declared once: a model name per physics effect, or a switch.

:data:`OPTIONS` is the one table of a scene's choices: what the TOML accepts, the defaults of the
scene's dataclasses (:mod:`signatelec.config.scene`), the DEM kernel's specialisation
(:class:`signatelec.engines.dem.spec.KernelSpec`) and the bench's cases all come from it.
Adding a model is one value here and, for a kernel option, one branch on its flag in the kernel.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from signatelec.config.lubricant import OILS
from signatelec.physics.contact import CONTACT_LAWS

FIDELITIES = ("dem", "quasistatic")


@dataclass(frozen=True)
class Option:
    """One choice of a scene, declared once in :data:`OPTIONS`.

    A physics option names a model; its ``off`` value is the null model that ``false`` selects
    (``true`` selects ``default``). A switch takes true or false. ``kernel``: the DEM kernel is
    compiled per value (:class:`signatelec.engines.dem.spec.KernelSpec` reads these options).
    """

    section: str
    name: str
    values: tuple
    default: str | bool
    description: str
    kernel: bool = False
    off: str | None = None
    #: The model ``true`` names when it is not the default (a model that is off by default).
    on: str | None = None

    @property
    def switch(self) -> bool:
        return isinstance(self.default, bool)

    def normalise(self, value: Any) -> Any:
        """The model a boolean names (``true``: the default, ``false``: ``off``), else value."""
        if self.off is not None and isinstance(value, bool):
            return (self.on or self.default) if value else self.off
        return value

    def accepts(self, value: Any) -> bool:
        if self.switch:
            return isinstance(value, bool)
        value = self.normalise(value)
        return isinstance(value, str) and value in self.values

    @property
    def rule(self) -> str:
        if self.switch:
            return "must be true or false"
        text = f"must be one of {', '.join(self.values)}"
        if self.off is not None:
            text += f" (true: {self.on or self.default}, false: {self.off})"
        return text


#: Every choice of a scene: what the TOML accepts, the defaults of the dataclasses below, the
#: kernel's specialisation and the bench's cases all come from this table. Costs: shares of the
#: seed scene's CPU time per step, ~0.45 us (``signatelec bench``).
OPTIONS: tuple[Option, ...] = (
    Option(
        "effects", "cage", ("balls", "rigid", "none"), "balls",
        "balls: 13 polyamide cage balls between two frictionless boundaries (table 2), ~40 % of "
        "the step, and they set the stability limit; rigid: one ball-guided ring body (x, y, "
        "angle) with a spherical pocket per ball (bearing.rigid_cage_material, "
        "pocket_clearance_m; conformal Hertz, frictionless), ~30 % cheaper a step than the "
        "cage balls and dt up to the steel balls' limit; none: balls touch (steel, frictionless)",
        kernel=True, off="none",
    ),
    Option(
        "effects", "friction", ("coulomb", "none"), "coulomb",
        "coulomb: tangential forces with the Coulomb limit (eq. 4) on ball/raceway contacts, "
        "~6 % of the step; none: frictionless (also when bearing.friction_coefficient = 0)",
        kernel=True, off="none",
    ),
    Option(
        "effects", "damping", ("critical", "none"), "critical",
        "critical: critical viscous damping (eq. 5) on every contact, ~15 % of the step; none: "
        "elastic contacts",
        kernel=True, off="none",
    ),
    Option(
        "effects", "contact_law", CONTACT_LAWS, "hertz",
        "hertz (eqs 6-9); harris (eqs 10-11, Harris' coefficients, same kernel); linear (eq. 3, "
        "Hertz secant stiffness at Stribeck's load, ~1/3 cheaper: no roots)",
        kernel=True,
    ),
    Option(
        "effects", "tangential", ("seed", "spring"), "seed",
        "seed: delta_t = v_t dt (eq. 3, first order in dt); spring: accumulated delta_t "
        "(second order, same cost)",
        kernel=True,
    ),
    Option(
        "effects", "gravity", ("standard", "none"), "standard",
        "standard: weight of every body along -y (9.80665 m/s^2), no cost; none: weightless",
        kernel=True, off="none",
    ),
    Option(
        "effects", "centrifugal", ("inertial", "compensated"), "inertial",
        "inertial: the inertial-frame DEM carries it, no cost; compensated: the centripetal "
        "force m v_t^2 / r on each ball cancels it, to compare with centrifugal-free theory",
        kernel=True, off="compensated",
    ),
    Option(
        "effects", "lubrication", ("ehl", "none"), "none",
        "ehl: oil films by Hamrock-Dowson, film capacitance and asperity conduction, the "
        "bearing's impedance at operating.measurement_frequency_hz (physics.ehl, "
        "physics.lubricated_contact), computed from the recorded kinematics after the run, "
        "~4 us per recorded instant (the dry electrical model's cost); none: the seed's dry "
        "contacts, nothing computed",
        off="none", on="ehl",
    ),
    Option(
        "lubricant", "oil", tuple(OILS), "ISO VG 68",
        "the oil of effects.lubrication (config.lubricant.OILS: ISO VG 32, 68, 100 mineral, PAO "
        "68), its properties overridable in [lubricant]; no cost when lubrication is none",
    ),
    Option(
        "procedure", "clearance_phase", (True, False), True,
        "move the outer race to R_out + clearance over clearance_time_s (eq. 14); false: at once",
    ),
    Option(
        "procedure", "spin_up", (True, False), True,
        "sinusoidal spin-up of the inner ring over spin_up_time_s; false: omega as a step",
    ),
    Option(
        "procedure", "load_ramp", ("smooth", "step"), "smooth",
        "smooth: F_r rises along (1 - cos)/2 over load_time_s; step: F_r applied at once",
    ),
    Option(
        "outputs", "electrical", (True, False), True,
        "contact ellipses, eq. 16 and the Kirchhoff network at every recorded instant "
        "(~3 us per instant, ~1 % of a seed run at 20 kHz)",
    ),
    Option(
        "outputs", "energy", (True, False), False,
        "energy balance (work in, dissipation, kinetic, elastic) per recorded instant, "
        "~20 % of the step",
        kernel=True,
    ),
    Option(
        "numerics", "integrator", ("verlet", "euler"), "verlet",
        "verlet: velocity Verlet, 2nd order; euler: symplectic Euler, 1st order, same cost per "
        "step and a stability limit about twice Verlet's with contact damping",
        kernel=True,
    ),
    Option(
        "numerics", "fidelity", FIDELITIES, "dem",
        "dem: the DEM kernel; quasistatic: the steady phase by the quasi-static tier (no "
        "dynamics, ~1 ms instead of ~0.2 s for the seed's scene; presets: engines.fidelity)",
    ),
)  # fmt: skip
OPTION_TABLE: dict[tuple[str, str], Option] = {(o.section, o.name): o for o in OPTIONS}
