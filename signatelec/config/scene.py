"""A scene: a bearing, an operating point, the procedure of the seed, the effects, the numerics.

Scenes are frozen dataclasses read from TOML and validated as a whole: any non-physical or unknown
value raises :class:`SceneError` with one line naming the key, the value and what is allowed.

TOML layout (every section and key optional; defaults are the seed's scene, section 4)::

    [bearing]      designation (a catalogue bearing, signatelec.config.catalogue; default: the
                   seed's), then any field of signatelec.config.bearing.Bearing to override it
    [operating]    radial_load_n, clearance_m, omega_rad_s, initial_ball_angle_rad,
                   injected_current_a, measurement_frequency_hz
    [procedure]    clearance_time_s, load_time_s, spin_up_time_s, load_ramp, clearance_phase,
                   spin_up
    [effects]      cage, friction, damping, contact_law, tangential, gravity, centrifugal,
                   lubrication
    [lubricant]    oil, temperature_c, any property of the oil, roughness (config.lubricant)
    [outputs]      electrical, energy
    [numerics]     dt_s, duration_s, sample_rate_hz, integrator, fidelity, linear_stiffness_n_m
    [loads]        unbalance_force_n (or unbalance_mass_kg, unbalance_eccentricity_m),
                   unbalance_phase_rad, load_table_time_s, load_table_radial_load_n
    [housing]      out_of_round_lobes, out_of_round_amplitude_m
    [[defects]]    location, angle_rad, length_m, depth_m, ball, profile (an array of tables;
                   signatelec.config.defects)

``procedure.spin_up_time_s``, ``numerics.dt_s`` and ``numerics.duration_s`` default to ``"auto"``:
the scene chooses them when it is built (:func:`resolve_auto`), and :attr:`Scene.chosen` names
what it chose; a number given instead is kept as given.

Every choice (a model name or a switch) is declared once in
:data:`signatelec.config.options.OPTIONS` with its allowed values, default and cost;
``[effects]`` holds the physics, each option naming a model.
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
from signatelec.config.catalogue import catalogue_bearing
from signatelec.config.constraints import (
    BOOLEAN,
    CLEARANCE_LIMIT_FRACTION,
    DT_MIN_S,
    NUMBER,
    OVERLAP_LIMIT_FRACTION,
    SCENE,
    Checker,
    Constraint,
)
from signatelec.config.defects import (
    ABNORMAL,
    DEFECT_LIMITS,
    DEPTH_LIMIT_FRACTION,
    MAX_DEFECTS,
    MAX_LOAD_TABLE_POINTS,
    TABLE,
    Defect,
    Housing,
    Loads,
)
from signatelec.config.lubricant import Lubricant
from signatelec.config.options import OPTION_TABLE
from signatelec.io import read_limited
from signatelec.physics.contact import hertz_normal_force, law_coefficients
from signatelec.physics.stability import auto_dt_s, auto_spin_up_time_s


class SceneError(ValueError):
    """A scene value that is not allowed; the message is one line naming key, value, rule."""


#: The value of a setting the scene chooses itself (see :func:`resolve_auto`).
AUTO = "auto"
#: Steady running an automatic duration keeps after the set-up: the seed's (30 ms - 7 ms set-up),
#: or STEADY_BALL_PASSES outer-race ball passes when they take longer (low speeds), s. The
#: passes are the 5 an estimate needs (measurement.band.MIN_BALL_PASSES) and one to spare: the
#: steady phase's recorded instants fall a fraction of one short of the phase.
STEADY_MIN_S = 0.023
STEADY_BALL_PASSES = 6


#: Keys the earlier layout had under [effects], and the section that holds them now.
_MOVED = {
    "clearance_phase": "procedure",
    "spin_up": "procedure",
    "electrical": "outputs",
    "energy": "outputs",
}


def _default(section: str, name: str) -> Any:
    return OPTION_TABLE[(section, name)].default


def _normalise(obj: Any, section: str) -> None:
    """Map the booleans of physics options to the model they name (frozen dataclasses)."""
    for f in fields(obj):
        option = OPTION_TABLE.get((section, f.name))
        if option is not None:
            object.__setattr__(obj, f.name, option.normalise(getattr(obj, f.name)))


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
    #: Frequency at which the lubricated bearing's impedance is reported, Hz.
    measurement_frequency_hz: float = 10e3


@dataclass(frozen=True)
class Procedure:
    """The seed's set-up phases (2.2.1, 2.2.2): clearance, load, spin-up; switches in OPTIONS."""

    clearance_time_s: float = 0.5e-3
    load_time_s: float = 1.5e-3
    #: "auto": long enough for the scene's speed, cage and clearance
    #: (signatelec.physics.stability.auto_spin_up_time_s; the seed's 5 ms at its scene).
    spin_up_time_s: float | str = AUTO
    load_ramp: str = _default("procedure", "load_ramp")
    clearance_phase: bool = _default("procedure", "clearance_phase")
    spin_up: bool = _default("procedure", "spin_up")


@dataclass(frozen=True)
class Effects:
    """The physics a scene simulates: each option names a model (config.options); a model that is
    not chosen is not compiled into the kernel. ``true``/``false`` name the default model and
    the null model of an on/off option (``cage = false`` is ``cage = "none"``)."""

    cage: str = _default("effects", "cage")
    friction: str = _default("effects", "friction")
    damping: str = _default("effects", "damping")
    contact_law: str = _default("effects", "contact_law")
    tangential: str = _default("effects", "tangential")
    gravity: str = _default("effects", "gravity")
    centrifugal: str = _default("effects", "centrifugal")
    lubrication: str = _default("effects", "lubrication")

    def __post_init__(self) -> None:
        _normalise(self, "effects")


@dataclass(frozen=True)
class Outputs:
    """What a run computes besides the motion (see config.options.OPTIONS)."""

    electrical: bool = _default("outputs", "electrical")
    energy: bool = _default("outputs", "energy")


@dataclass(frozen=True)
class Numerics:
    #: "auto": 0.9 x the stability limit, at most 1e-7 s (physics.stability.auto_dt_s).
    dt_s: float | str = AUTO
    #: "auto": the set-up, then max(STEADY_MIN_S, STEADY_BALL_PASSES ball passes) of steady
    #: running (the seed's 30 ms at its scene).
    duration_s: float | str = AUTO
    sample_rate_hz: float = 20000.0
    integrator: str = _default("numerics", "integrator")
    fidelity: str = _default("numerics", "fidelity")
    #: Linear-law stiffness of the ball/outer-raceway contact, N/m; 0 means the Hertz secant
    #: stiffness at the Stribeck load 4.37 F_r / Z (see contact.law_coefficients).
    linear_stiffness_n_m: float = 0.0


#: The sections of a scene after [bearing], in TOML order.
SECTIONS: dict[str, type] = {
    "operating": Operating,
    "procedure": Procedure,
    "effects": Effects,
    "lubricant": Lubricant,
    "outputs": Outputs,
    "numerics": Numerics,
    "loads": Loads,
    "housing": Housing,
}


@dataclass(frozen=True)
class Scene:
    bearing: Bearing = field(default_factory=Bearing)
    operating: Operating = field(default_factory=Operating)
    procedure: Procedure = field(default_factory=Procedure)
    effects: Effects = field(default_factory=Effects)
    lubricant: Lubricant = field(default_factory=Lubricant)
    outputs: Outputs = field(default_factory=Outputs)
    numerics: Numerics = field(default_factory=Numerics)
    loads: Loads = field(default_factory=Loads)
    housing: Housing = field(default_factory=Housing)
    #: Localised defects (signatelec.config.defects.Defect), TOML ``[[defects]]``.
    defects: tuple = ()
    #: The settings the scene chose itself, ``(("numerics.dt_s", 1e-07), ...)``; a copy made
    #: with other values chooses them again unless its own value is given.
    chosen: tuple = field(default=(), compare=False, repr=False)

    def __post_init__(self) -> None:
        if isinstance(self.defects, list):
            object.__setattr__(self, "defects", tuple(self.defects))
        resolve_auto(self)
        validate_scene(self)

    @property
    def auto(self) -> dict[str, float]:
        """The chosen settings as ``{"numerics.dt_s": 1e-07, ...}``."""
        return dict(self.chosen)

    # --- derived ------------------------------------------------------------------------
    @property
    def setup_time_s(self) -> float:
        """End of the set-up (clearance, load and spin-up phases)."""
        p = self.procedure
        return p.clearance_time_s + p.load_time_s + p.spin_up_time_s

    @property
    def abnormal(self) -> bool:
        """Whether the scene has a defect, an unbalance, a load table or an out-of-round ring
        (then its signals are not periodic with the ball pass)."""
        loads = self.loads
        unbalance = loads.unbalance_amplitude_n(self.operating.omega_rad_s) > 0.0
        return bool(self.defects) or unbalance or loads.has_table or self.housing.out_of_round

    @property
    def n_steps(self) -> int:
        return int(round(self.numerics.duration_s / self.numerics.dt_s))

    @property
    def record_every(self) -> int:
        """Steps between two recorded samples."""
        return max(1, int(round(1.0 / (self.numerics.sample_rate_hz * self.numerics.dt_s))))

    # --- (de)serialisation ----------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        sections = {name: asdict(getattr(self, name)) for name in SECTIONS}
        for key in ("load_table_time_s", "load_table_radial_load_n"):
            sections["loads"][key] = list(sections["loads"][key])
        defects = [asdict(d) for d in self.defects]
        return {"bearing": self.bearing.to_dict()} | sections | {"defects": defects}

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scene:
        sections = SECTIONS
        check = Checker(SceneError)
        if not isinstance(data, dict):
            check.fail("scene", data, "must be a table of sections")
        check.keys("", data, ["bearing", *sections, "defects"], noun="section")
        kwargs: dict[str, Any] = {}
        for name, value in data.items():
            if name == "bearing":
                try:
                    table = check.table(name, value)
                    if "designation" in table:  # a catalogue bearing, its fields overridable
                        rest = {k: v for k, v in table.items() if k != "designation"}
                        kwargs["bearing"] = catalogue_bearing(table["designation"], **rest)
                    else:
                        kwargs["bearing"] = Bearing.from_dict(table)
                except BearingError as exc:
                    raise SceneError(str(exc)) from None
                except TypeError as exc:
                    raise SceneError(f"bearing: {exc}") from None
            elif name == "defects":
                kwargs[name] = _defects(value)
            else:
                kwargs[name] = _section(name, sections[name], value)
        return cls(**kwargs)

    @classmethod
    def from_toml(cls, path: str | Path) -> Scene:
        return cls.from_dict(read_toml(path, f"scene file {str(path)!r}", "a scene", SceneError))

    def with_overrides(self, **changes: Any) -> Scene:
        """Copy with flat overrides such as ``radial_load_n=...`` or ``dt_s=...`` (None skipped)."""
        parts: dict[str, dict] = {name: {} for name in SECTIONS}
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
        # a chosen setting given again is the caller's; the others are chosen again
        given = {f"{s}.{k}" for s, v in parts.items() for k in v}
        chosen = tuple((k, v) for k, v in self.chosen if k not in given)
        return replace(self, **updated, chosen=chosen)


#: Settings that may be "auto", in the order they are chosen (each may use those before it).
AUTO_KEYS = ("procedure.spin_up_time_s", "numerics.dt_s", "numerics.duration_s")


def _auto_duration_s(scene: Scene) -> float:
    b = scene.bearing
    passes_hz = b.ball_pass_frequency_hz(scene.operating.omega_rad_s)
    steady = STEADY_MIN_S
    if passes_hz > 0.0:
        steady = max(steady, STEADY_BALL_PASSES / passes_hz)
    return scene.setup_time_s + steady


_RULES = {
    "procedure.spin_up_time_s": auto_spin_up_time_s,
    "numerics.dt_s": auto_dt_s,
    "numerics.duration_s": _auto_duration_s,
}
#: Stand-ins while a setting is being chosen (the seed's values).
_PLACEHOLDERS = {
    "procedure.spin_up_time_s": 5.0e-3,
    "numerics.dt_s": 1e-7,
    "numerics.duration_s": 0.03,
}


def resolve_auto(scene: Scene) -> None:
    """Replace the ``"auto"`` settings of ``scene`` (being built) by the values their rules give.

    A setting is chosen again when its value is ``"auto"`` or still the value chosen for the
    scene it was copied from (:attr:`Scene.chosen`). A rule that cannot be evaluated (a value
    out of range elsewhere in the scene) leaves the seed's value, and validation then names the
    value at fault.
    """
    previous = dict(scene.chosen)
    todo = []
    for key in AUTO_KEYS:
        section, name = key.split(".")
        value = getattr(getattr(scene, section), name)
        if value == AUTO or (key in previous and value == previous[key]):
            todo.append(key)
            _set(scene, key, _PLACEHOLDERS[key])
    chosen = {}
    for key in todo:
        try:
            value = float(_RULES[key](scene))
        except (ArithmeticError, ValueError, TypeError):
            value = _PLACEHOLDERS[key]
        if not math.isfinite(value) or value <= 0.0:
            value = _PLACEHOLDERS[key]
        if key == "numerics.dt_s":
            # a limit below the smallest allowed step: the run budget says no step runs it
            value = max(value, DT_MIN_S)
        _set(scene, key, value)
        chosen[key] = value
    object.__setattr__(scene, "chosen", tuple(chosen.items()))


def _set(scene: Scene, key: str, value: float) -> None:
    section, name = key.split(".")
    object.__setattr__(scene, section, replace(getattr(scene, section), **{name: value}))


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
    if isinstance(f.default, bool):
        return Constraint(section, f.name, BOOLEAN)
    if isinstance(f.default, float) or f.default == AUTO:
        return Constraint(section, f.name, NUMBER)
    return None


def _section(name: str, cls: type, data: Any) -> Any:
    """A scene section from its TOML table: known keys (a key that moved names its new
    section), options among their values, numbers checked before they are converted."""
    check = Checker(SceneError)
    table = check.table(name, data)
    known = [f.name for f in fields(cls)]
    for key, value in table.items():
        if key not in known:
            moved = f"; [{_MOVED[key]}] holds it now" if key in _MOVED else ""
            check.fail(f"{name}.{key}", value, f"unknown key; allowed: {', '.join(known)}{moved}")
    converted = {}
    for f in fields(cls):
        if f.name not in table:
            continue
        value = table[f.name]
        option = OPTION_TABLE.get((name, f.name))
        if option is not None:
            if not option.accepts(value):
                check.fail(f"{name}.{f.name}", value, option.rule)
            converted[f.name] = value
        else:
            row = type_row(name, f)
            if f.default == AUTO and value == AUTO:
                converted[f.name] = value
            elif f.default == AUTO and (isinstance(value, (str, bool)) or value is None):
                check.fail(f"{name}.{f.name}", value, f'must be a number or "{AUTO}"')
            else:
                converted[f.name] = value if row is None else check.check(row, value)
    return cls(**converted)


def _defects(data: Any) -> tuple[Defect, ...]:
    """The defects of a TOML ``[[defects]]`` array of tables."""
    check = Checker(SceneError)
    if not isinstance(data, list):
        check.fail("defects", data, "must be an array of tables ([[defects]])")
    if len(data) > MAX_DEFECTS:
        check.fail("defects", f"{len(data)} tables", f"at most {MAX_DEFECTS} defects")
    return tuple(Defect.from_dict(item, f"defects[{i}]", SceneError) for i, item in enumerate(data))


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
        "viscosity_falls": lambda: (
            (oil := scene.lubricant.oil_data()).viscosity_100c_mm2_s < oil.viscosity_40c_mm2_s
        ),
        "permittivity_physical": lambda: (
            scene.lubricant.relative_permittivity in (0.0, 0)
            or scene.lubricant.relative_permittivity >= 1.0
        ),
    }


def _validate_abnormal(scene: Scene) -> None:
    """The rows of [loads] and [housing], the load table element by element, the defects."""
    b, op, loads, housing = scene.bearing, scene.operating, scene.loads, scene.housing
    table_t, table_f = loads.load_table_time_s, loads.load_table_radial_load_n
    # (called by the rows that need them, after the table and the numbers are checked)
    largest = lambda: max((op.radial_load_n, *table_f))  # noqa: E731
    unbalance = lambda: loads.unbalance_amplitude_n(op.omega_rad_s)  # noqa: E731
    limits = scene_limits(scene) | {
        "one_unbalance_form": lambda: (
            loads.unbalance_force_n == 0.0
            or loads.unbalance_mass_kg * loads.unbalance_eccentricity_m == 0.0
        ),
        "unbalance_within_limit": lambda: unbalance() + largest() <= radial_load_limit_n(b),
        "unbalance_n": unbalance,
        "largest_load_n": largest,
        "lobes_given": lambda: (
            housing.out_of_round_lobes >= 1 or housing.out_of_round_amplitude_m == 0
        ),
    }
    check = Checker(SceneError, limits=limits)
    for key, values in (("load_table_time_s", table_t), ("load_table_radial_load_n", table_f)):
        if not isinstance(values, tuple) or len(values) > MAX_LOAD_TABLE_POINTS:
            allowed = f"must be an array of at most {MAX_LOAD_TABLE_POINTS} numbers"
            check.fail(f"loads.{key}", values, allowed)
        for i, value in enumerate(values):
            row = TABLE[0] if key == "load_table_time_s" else TABLE[1]
            check.check(row, value, f"loads.{key}[{i}]")
    if len(table_t) != len(table_f):
        check.fail(
            "loads.load_table_radial_load_n",
            table_f,
            f"must have as many points as load_table_time_s ({len(table_t)})",
        )
    for i in range(1, len(table_t)):
        if not table_t[i] > table_t[i - 1]:
            check.fail(f"loads.load_table_time_s[{i}]", table_t[i], "times must increase")
    for row in ABNORMAL:
        check.check(row, getattr(getattr(scene, row.section), row.key))
    r_out = b.outer_race_radius_m + op.clearance_m
    radii = {"outer": r_out, "inner": b.inner_race_radius_m, "ball": b.ball_radius_m}
    names = {"outer": "outer race", "inner": "inner race", "ball": "ball"}
    if len(scene.defects) > MAX_DEFECTS:
        check.fail("defects", f"{len(scene.defects)} defects", f"at most {MAX_DEFECTS}")
    for i, d in enumerate(scene.defects):
        if not isinstance(d, Defect):
            check.fail(f"defects[{i}]", d, "must be a Defect")
        one = Checker(
            SceneError,
            limits={
                "surface_length_m": 2.0 * math.pi * radii.get(d.location, math.inf),
                "surface": names.get(d.location, d.location),
                "depth_limit_m": DEPTH_LIMIT_FRACTION * b.ball_radius_m,
                "last_ball": b.n_balls - 1,
            },
        )
        values = Defect.from_dict(asdict(d), f"defects[{i}]", SceneError)
        for row in DEFECT_LIMITS:
            one.check(row, getattr(values, row.key), f"defects[{i}].{row.key}")


def validate_scene(scene: Scene) -> None:
    """Raise :class:`SceneError` on the first value that is not allowed: every option among its
    values and every number's type, then the rows of :data:`signatelec.config.constraints.SCENE`
    in order."""
    check = Checker(SceneError, limits=scene_limits(scene))
    for section in SECTIONS:
        obj = getattr(scene, section)
        for f in fields(obj):
            value = getattr(obj, f.name)
            option = OPTION_TABLE.get((section, f.name))
            if option is not None:
                if not option.accepts(value):
                    check.fail(f"{section}.{f.name}", value, option.rule)
                continue
            row = type_row(section, f)
            if row is not None:
                check.check(row, value)
    for row in SCENE:
        check.check(row, getattr(getattr(scene, row.section), row.key))
    _validate_abnormal(scene)


DEFAULT_SCENE = Scene()
