"""A scene: a bearing, an operating point, the procedure of the seed, the effects, the numerics.

Scenes are frozen dataclasses read from TOML and validated as a whole: any non-physical or unknown
value raises :class:`SceneError` with one line naming the key, the value and what is allowed.

TOML layout (every section and key optional; defaults are the seed's scene, section 4)::

    [bearing]      # fields of signatelec.config.bearing.Bearing (radii, n_balls, materials, ...)
    [operating]    radial_load_n, clearance_m, omega_rad_s, initial_ball_angle_rad,
                   injected_current_a
    [procedure]    clearance_time_s, load_time_s, spin_up_time_s, load_ramp
    [effects]      cage, friction, damping, contact_law, tangential, gravity, centrifugal,
                   clearance_phase, spin_up, electrical, energy
    [numerics]     dt_s, duration_s, sample_rate_hz, integrator, fidelity, linear_stiffness_n_m
"""

from __future__ import annotations

import errno
import functools
import json
import math
import os
import tomllib
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from signatelec.config.bearing import INNER, OUTER, Bearing, BearingError
from signatelec.config.constraints import (
    BOOLEAN,
    CHOICE,
    CLEARANCE_LIMIT_FRACTION,
    NUMBER,
    OVERLAP_LIMIT_FRACTION,
    SCENE,
    Checker,
    Constraint,
)
from signatelec.io import read_limited
from signatelec.physics.contact import CONTACT_LAWS, hertz_normal_force, law_coefficients


class SceneError(ValueError):
    """A scene value that is not allowed; the message is one line naming key, value, rule."""


INTEGRATORS = ("verlet", "euler")
TANGENTIAL_MODELS = ("seed", "spring")
LOAD_RAMPS = ("smooth", "step")
#: "dem": the DEM kernel; "quasistatic": the steady phase by signatelec.engines.quasistatic.tier (no
#: dynamics: ~1 ms instead of ~0.2 s for the seed's scene). Presets: signatelec.engines.fidelity.
FIDELITIES = ("dem", "quasistatic")


@dataclass(frozen=True)
class Operating:
    """Operating point (seed section 2.2.2 and 4)."""

    #: Radial load F_r on the inner ring along -y, N (seed: 5820 N = 0.2 C_r).
    radial_load_n: float = 5820.0
    #: Radial clearance Delta_r = R_out^f - R_out (eq. 14): > 0 clearance, < 0 preload, m.
    clearance_m: float = 0.0
    #: Inner-ring speed omega after the spin-up, rad/s (seed: 500 rad/s).
    omega_rad_s: float = 500.0
    #: Angle of ball 0 from the load direction at t = 0, rad.
    initial_ball_angle_rad: float = 0.0
    #: Current injected into the outer ring for the electrical model, A.
    injected_current_a: float = 0.1


@dataclass(frozen=True)
class Procedure:
    """Durations of the seed's set-up phases (2.2.1, 2.2.2): clearance, load, spin-up."""

    clearance_time_s: float = 0.5e-3
    load_time_s: float = 1.5e-3
    spin_up_time_s: float = 5.0e-3
    #: "smooth": F_r rises along (1 - cos)/2 over load_time_s; "step": F_r applied at once.
    load_ramp: str = "smooth"


@dataclass(frozen=True)
class Effects:
    """Which physics a scene simulates. An effect that is off is not compiled into the kernel.

    - ``cage``: the 13 polyamide cage balls between two frictionless boundaries (off: balls may
      touch each other, steel on steel, frictionless).
    - ``friction``: Coulomb friction (eq. 4) and tangential forces on ball/raceway contacts.
    - ``damping``: critical viscous damping (eq. 5) on every contact.
    - ``contact_law``: "hertz" (eqs 6-9), "harris" (eqs 10-11) or "linear" (eq. 3).
    - ``tangential``: "seed" (delta_t = v_t dt, eq. 3) or "spring" (accumulated delta_t).
    - ``gravity``: weight of balls, cage balls and inner ring along -y.
    - ``centrifugal``: the inertial-frame DEM carries it by itself; off adds the centripetal force
      m v_t^2 / r to each ball so results compare with centrifugal-free theory.
    - ``clearance_phase``: move the outer race to R_out + clearance gradually (eq. 14); off: at
      once.
    - ``spin_up``: sinusoidal spin-up of the inner ring; off: omega applied as a step.
    - ``electrical``: contact ellipses, eq. 16 and the Kirchhoff network, per recorded instant.
    - ``energy``: accumulate an energy balance (work in, dissipation, kinetic, elastic).
    """

    cage: bool = True
    friction: bool = True
    damping: bool = True
    contact_law: str = "hertz"
    tangential: str = "seed"
    gravity: bool = True
    centrifugal: bool = True
    clearance_phase: bool = True
    spin_up: bool = True
    electrical: bool = True
    energy: bool = False


@dataclass(frozen=True)
class Numerics:
    dt_s: float = 1e-7
    duration_s: float = 0.03
    sample_rate_hz: float = 20000.0
    integrator: str = "verlet"
    fidelity: str = "dem"
    #: Linear-law stiffness of the ball/outer-raceway contact, N/m; 0 means the Hertz secant
    #: stiffness at the Stribeck load 4.37 F_r / Z (see contact.law_coefficients).
    linear_stiffness_n_m: float = 0.0


_CHOICES = {
    ("effects", "contact_law"): CONTACT_LAWS,
    ("effects", "tangential"): TANGENTIAL_MODELS,
    ("procedure", "load_ramp"): LOAD_RAMPS,
    ("numerics", "integrator"): INTEGRATORS,
    ("numerics", "fidelity"): FIDELITIES,
}


@dataclass(frozen=True)
class Scene:
    bearing: Bearing = field(default_factory=Bearing)
    operating: Operating = field(default_factory=Operating)
    procedure: Procedure = field(default_factory=Procedure)
    effects: Effects = field(default_factory=Effects)
    numerics: Numerics = field(default_factory=Numerics)

    def __post_init__(self) -> None:
        validate_scene(self)

    # --- derived ------------------------------------------------------------------------
    @property
    def setup_time_s(self) -> float:
        """End of the set-up (clearance, load and spin-up phases)."""
        p = self.procedure
        return p.clearance_time_s + p.load_time_s + p.spin_up_time_s

    @property
    def n_steps(self) -> int:
        return int(round(self.numerics.duration_s / self.numerics.dt_s))

    @property
    def record_every(self) -> int:
        """Steps between two recorded samples."""
        return max(1, int(round(1.0 / (self.numerics.sample_rate_hz * self.numerics.dt_s))))

    # --- (de)serialisation ----------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "bearing": self.bearing.to_dict(),
            "operating": asdict(self.operating),
            "procedure": asdict(self.procedure),
            "effects": asdict(self.effects),
            "numerics": asdict(self.numerics),
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scene:
        sections = {
            "operating": Operating,
            "procedure": Procedure,
            "effects": Effects,
            "numerics": Numerics,
        }
        check = Checker(SceneError)
        if not isinstance(data, dict):
            check.fail("scene", data, "must be a table of sections")
        check.keys("", data, ["bearing", *sections], noun="section")
        kwargs: dict[str, Any] = {}
        for name, value in data.items():
            if name == "bearing":
                try:
                    kwargs["bearing"] = Bearing.from_dict(check.table(name, value))
                except BearingError as exc:
                    raise SceneError(str(exc)) from None
                except TypeError as exc:
                    raise SceneError(f"bearing: {exc}") from None
            else:
                kwargs[name] = _section(name, sections[name], value)
        return cls(**kwargs)

    @classmethod
    def from_toml(cls, path: str | Path) -> Scene:
        return cls.from_dict(read_toml(path, f"scene file {str(path)!r}", "a scene", SceneError))

    def with_overrides(self, **changes: Any) -> Scene:
        """Copy with flat overrides such as ``radial_load_n=...`` or ``dt_s=...`` (None skipped)."""
        parts = {"operating": {}, "procedure": {}, "effects": {}, "numerics": {}}
        for key, value in changes.items():
            if value is None:
                continue
            for section in parts:
                if key in {f.name for f in fields(getattr(self, section))}:
                    parts[section][key] = value
                    break
            else:
                raise SceneError(f"{key} = {value!r}: not a scene parameter")
        updated = {s: replace(getattr(self, s), **v) for s, v in parts.items() if v}
        return replace(self, **updated)


#: Largest scene file or dataset spec read, bytes: far above any real one (a few kB), small
#: enough that a device such as /dev/zero or a misnamed data file is refused at once.
TOML_MAX_BYTES = 10 * 1024**2


def read_toml(path: str | Path, label: str, noun: str, error: type[ValueError]) -> dict:
    """A UTF-8 TOML file as a dict; on failure ``error`` with one line starting with ``label``.

    The file is read up to :data:`TOML_MAX_BYTES` (a larger file or an endless device is refused
    after reading one byte more); an empty path is refused, not taken as no file.
    """
    if not os.fspath(path).strip():
        raise error(f"{label}: must name a file; {noun} is a UTF-8 TOML file")
    try:
        data = read_limited(path, TOML_MAX_BYTES)
    except OSError as exc:
        if exc.errno == errno.EFBIG:
            raise error(
                f"{label}: is larger than {TOML_MAX_BYTES // 1024**2} MiB; {noun} is a small "
                "UTF-8 TOML file"
            ) from None
        raise error(f"{label}: cannot be read ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise error(f"{label}: is not UTF-8 text; {noun} is a UTF-8 TOML file") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{label}: not valid TOML ({exc})") from None


@functools.cache
def type_row(section: str, f) -> Constraint | None:
    """The type rule of a scene key, from its dataclass field: one of its choices, true or
    false, or a number (the ranges are rows of :data:`signatelec.config.constraints.SCENE`)."""
    if (section, f.name) in _CHOICES:
        return Constraint(section, f.name, CHOICE, choices=_CHOICES[(section, f.name)])
    if isinstance(f.default, bool):
        return Constraint(section, f.name, BOOLEAN)
    if isinstance(f.default, float):
        return Constraint(section, f.name, NUMBER)
    return None


def _section(name: str, cls: type, data: Any) -> Any:
    """A scene section from its TOML table: known keys, each of its type, numbers as floats (a
    number is checked before it is converted)."""
    check = Checker(SceneError)
    check.keys(name, check.table(name, data), [f.name for f in fields(cls)])
    rows = {f.name: type_row(name, f) for f in fields(cls)}
    converted = {
        key: value if rows[key] is None else check.check(rows[key], value)
        for key, value in data.items()
    }
    return cls(**converted)


# --- named limits of the scene table (physics rules) -------------------------------------------


@functools.lru_cache(maxsize=32)
def ball_load_limit_n(bearing: Bearing) -> float:
    """Ball/raceway force whose Hertz overlap is OVERLAP_LIMIT_FRACTION of the ball radius, N.

    The smaller of the inner and outer contacts (seed eqs 6, 8, 12-13), whatever the scene's law.
    """
    coef, _ = law_coefficients(bearing, "hertz")
    overlap = OVERLAP_LIMIT_FRACTION * bearing.ball_radius_m
    return float(min(hertz_normal_force(overlap, coef[i]) for i in (INNER, OUTER)))


def radial_load_limit_n(bearing: Bearing) -> float:
    """F_r whose Stribeck largest ball load 4.37 F_r / Z reaches :func:`ball_load_limit_n`."""
    return ball_load_limit_n(bearing) * bearing.n_balls / 4.37


def omega_limit_rad_s(bearing: Bearing) -> float:
    """Inner-ring speed whose ball centrifugal force m r_p omega_c^2 reaches
    :func:`ball_load_limit_n` (cage speed omega_c = omega R_inn / (R_inn + R_out))."""
    return (
        math.sqrt(ball_load_limit_n(bearing) / (bearing.ball_mass_kg * bearing.pitch_radius_m))
        * (bearing.inner_race_radius_m + bearing.outer_race_radius_m)
        / bearing.inner_race_radius_m
    )


@functools.lru_cache(maxsize=32)
def preload_limit_m(bearing: Bearing) -> float:
    """Largest preload (ISO 76 static pressure): signatelec.physics.quasistatic.preload_limit_m."""
    from signatelec.physics.quasistatic import preload_limit_m as limit

    return limit(bearing)


def scene_limits(scene: Scene) -> dict[str, Any]:
    """The limits that rows of the scene table name, as functions of ``scene``."""
    b, nu = scene.bearing, scene.numerics
    return {
        "radial_load_limit_n": functools.partial(radial_load_limit_n, b),
        "omega_limit_rad_s": functools.partial(omega_limit_rad_s, b),
        "clearance_limit_m": lambda: CLEARANCE_LIMIT_FRACTION * b.ball_radius_m,
        "preload_limit_m": functools.partial(preload_limit_m, b),
        "setup_time_s": lambda: scene.setup_time_s,
        "sample_rate_limit_hz": lambda: 1.0 / nu.dt_s,
        "sample_rate_floor_hz": lambda: 1.0 / nu.duration_s,
    }


def validate_scene(scene: Scene) -> None:
    """Raise :class:`SceneError` on the first value that is not allowed: every key's type, then
    the rows of :data:`signatelec.config.constraints.SCENE` in order."""
    check = Checker(SceneError, limits=scene_limits(scene))
    for section in ("operating", "procedure", "effects", "numerics"):
        obj = getattr(scene, section)
        for f in fields(obj):
            row = type_row(section, f)
            if row is not None:
                check.check(row, getattr(obj, f.name))
    for row in SCENE:
        check.check(row, getattr(getattr(scene, row.section), row.key))


DEFAULT_SCENE = Scene()
