"""What input values are allowed: one declarative table, and the one checker that applies it.

A :class:`Constraint` row names a section and a key, the kind of value (``number``, ``integer``,
``boolean``, ``string``, ``choice`` or ``interval``: a number or a ``[low, high]`` array), its
range or rule, and the text saying what is allowed. :class:`Checker` applies rows; a failure is
one line ``<where>: <section>.<key> = <value>: <what is allowed>``, raised as the caller's error
class (``SceneError``, ``SpecError``, ``BearingError``); the command line prints it and exits
with code 2.

Bounds, choices and rules that depend on the rest of the input or on physics (the set-up time,
1/dt, the Hertz overlap limit, the ISO 76 preload limit, balls that fit on the pitch circle) are
:class:`Limit` references: named quantities that the validator supplies as functions, evaluated
when a row needs them. This module imports nothing else of signatelec, so the bearing (the lowest
configuration) is checked by it too.

Numbers are compared with their bounds as given, before any conversion: a 400-digit TOML integer
is out of range (or, with no bound, not a finite number), never an ``OverflowError``.

Tables: :data:`BEARING`, :data:`MATERIAL` and :data:`SCENE` (scene files: ``signatelec.config
.scene``; the type of every scene key comes from its dataclass field, these rows add the ranges),
:data:`DATASET`, :data:`DESIGN`, :data:`FACTOR` and :data:`MEASUREMENT` (dataset specs:
``signatelec.data.spec``).
"""

from __future__ import annotations

import math
import numbers
import sys
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, NoReturn

NUMBER, INTEGER, BOOLEAN, STRING, CHOICE, INTERVAL = (
    "number",
    "integer",
    "boolean",
    "string",
    "choice",
    "interval",
)
KINDS = (NUMBER, INTEGER, BOOLEAN, STRING, CHOICE, INTERVAL)


class ConstraintError(ValueError):
    """A value that is not allowed (when the caller names no error class of its own)."""


@dataclass(frozen=True)
class Limit:
    """A named quantity the validator supplies (a bound, a list of choices or a rule's verdict);
    ``scale`` multiplies a numeric one (``Limit("preload_limit_m", -1.0)``: the lowest clearance).
    """

    name: str
    scale: float = 1.0


Bound = float | int | Limit | None


@dataclass(frozen=True)
class Constraint:
    """One rule on one key. ``allowed``, when given, is the text of every failure of the row
    (type, range or rule); it may name ``{value}``, ``{low}``, ``{high}``, ``{choices}`` and any
    limit the validator supplies. Without it the text is generated from the kind and range."""

    section: str
    key: str
    kind: str
    low: Bound = None
    high: Bound = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple[str, ...] | Limit = ()
    #: A limit whose value says whether the rule holds (a physics rule of the whole input).
    rule: Limit | None = None
    allowed: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"{self.section}.{self.key}: kind {self.kind!r} not in {KINDS}")

    @property
    def name(self) -> str:
        return f"{self.section}.{self.key}"


def short(value: Any) -> str:
    """``repr(value)``, cut to 60 characters (a 400-digit integer stays one readable line)."""
    text = repr(value)
    return text if len(text) < 60 else text[:57] + "..."


def _is_number(value: Any) -> bool:
    kind = type(value)
    if kind is float or kind is int:  # the common case, without the slower ABC check
        return True
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _is_integer(value: Any) -> bool:
    if type(value) is int:
        return True
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _representable(value: Any) -> bool:
    """A finite float, or an integer within the float range (compared exactly, not converted)."""
    if _is_integer(value):
        return abs(int(value)) <= sys.float_info.max
    return math.isfinite(value)


_FLOAT_RANGE = f"must be a finite number (at most {sys.float_info.max:.4g} in magnitude)"


class _Fields(dict):
    """Format fields of a row's ``allowed`` text, each resolved when the text names it: the
    value, the row's bounds and choices, then any limit of the checker."""

    def __init__(self, checker: Checker, row: Constraint, value: Any):
        super().__init__(value=value)
        self.checker, self.row = checker, row

    def __missing__(self, name: str) -> Any:
        if name in ("low", "high"):
            return self.checker._resolve(getattr(self.row, name))
        if name == "choices":
            return ", ".join(self.checker._resolve(self.row.choices))
        return self.checker.limit(Limit(name))


class Checker:
    """Applies constraint rows; raises ``error("<where>: <key> = <value>: <allowed>")``.

    ``limits`` maps the names of :class:`Limit` references to values or to functions of no
    argument (called once, when a row first needs them).
    """

    def __init__(
        self,
        error: type[Exception] = ConstraintError,
        where: str = "",
        limits: Mapping[str, Any] | None = None,
    ):
        self.error = error
        self.where = where
        self._limits = dict(limits or {})
        self._known: dict[str, Any] = {}

    def fail(self, key: str, value: Any, allowed: str) -> NoReturn:
        prefix = f"{self.where}: " if self.where else ""
        raise self.error(f"{prefix}{key} = {short(value)}: {allowed}")

    def limit(self, ref: Limit) -> Any:
        if ref.name not in self._known:
            if ref.name not in self._limits:
                raise KeyError(f"limit {ref.name!r} is not supplied to this checker")
            supplied = self._limits[ref.name]
            self._known[ref.name] = supplied() if callable(supplied) else supplied
        value = self._known[ref.name]
        return value * ref.scale if ref.scale != 1.0 else value

    def _resolve(self, bound: Any) -> Any:
        return self.limit(bound) if isinstance(bound, Limit) else bound

    # --- structure --------------------------------------------------------------------------
    def table(self, key: str, value: Any) -> dict:
        if not isinstance(value, dict):
            self.fail(key, value, "must be a table")
        return value

    def keys(self, key: str, table: dict, allowed: Iterable[str], noun: str = "key") -> None:
        allowed = tuple(allowed)
        for k, v in table.items():
            if k not in allowed:
                where = f"{key}.{k}" if key else k
                self.fail(where, v, f"unknown {noun}; allowed: {', '.join(allowed)}")

    # --- values -----------------------------------------------------------------------------
    def check(self, row: Constraint, value: Any, key: str | None = None) -> Any:
        """The value if ``row`` allows it (a float for a number, a (low, high) tuple for an
        interval), else raise. ``key``: the name to print (default ``section.key``)."""
        key = key or row.name
        if row.kind == INTERVAL:
            return self._interval(row, value, key)
        if row.kind == NUMBER:
            if not _is_number(value):
                self._refuse(row, key, value, "must be a number")
            if not _is_integer(value) and not math.isfinite(value):
                self._refuse(row, key, value, "must be a finite number")
        elif row.kind == INTEGER:
            if not _is_integer(value):
                self._refuse(row, key, value, "must be an integer")
        elif row.kind == BOOLEAN:
            if not isinstance(value, bool):
                self._refuse(row, key, value, "must be true or false")
        elif row.kind == STRING:
            if not isinstance(value, str):
                self._refuse(row, key, value, "must be a string")
        elif row.kind == CHOICE:
            choices = self._resolve(row.choices)
            if not isinstance(value, str) or value not in choices:
                self._refuse(row, key, value, f"must be one of {', '.join(choices)}")
        if row.kind in (NUMBER, INTEGER):
            self._range(row, key, value)
            if row.kind == NUMBER and not _representable(value):
                self._refuse(row, key, value, _FLOAT_RANGE)
        if row.rule is not None and not self.limit(row.rule):
            self._refuse(row, key, value, "is not allowed")
        if row.kind == NUMBER:
            return float(value)
        if row.kind == INTEGER:
            return int(value)
        return value

    def _range(self, row: Constraint, key: str, value: Any) -> None:
        low, high = self._resolve(row.low), self._resolve(row.high)
        below = low is not None and (value < low or (row.low_open and value == low))
        above = high is not None and (value > high or (row.high_open and value == high))
        if below or above:
            self._refuse(row, key, value, _range_text(row, low, high))

    def _interval(self, row: Constraint, value: Any, key: str) -> tuple[float, float]:
        """A number (fixed) or a [low, high] array (drawn uniformly per trace)."""
        element = Constraint(
            row.section, row.key, NUMBER, row.low, row.high, row.low_open, row.high_open
        )
        if isinstance(value, list):
            if len(value) != 2:
                self.fail(key, value, "must be a number or a [low, high] array")
            a = self.check(element, value[0], f"{key}[0]")
            b = self.check(element, value[1], f"{key}[1]")
            if b < a:
                self.fail(key, value, "must be [low, high] with low <= high")
            return (a, b)
        x = self.check(element, value, key)
        return (x, x)

    def _refuse(self, row: Constraint, key: str, value: Any, generated: str) -> NoReturn:
        if not row.allowed:
            self.fail(key, value, generated)
        self.fail(key, value, row.allowed.format_map(_Fields(self, row, value)))


def _range_text(row: Constraint, low: Any, high: Any) -> str:
    noun = "an integer " if row.kind == INTEGER else ""
    if row.kind == INTEGER and low is not None and high is not None:
        return f"must be an integer in [{low}, {high}]"
    if low is not None and high is not None:
        left, right = "(" if row.low_open else "[", ")" if row.high_open else "]"
        return f"must be in {left}{low:g}, {high:g}{right}"
    if low is not None:
        return f"must be {noun}{'>' if row.low_open else '>='} {low:g}"
    return f"must be {noun}{'<' if row.high_open else '<='} {high:g}"


def row_of(table: Iterable[Constraint], section: str, key: str) -> Constraint:
    """The one row of ``section.key`` in ``table``."""
    (row,) = [row for row in table if row.section == section and row.key == key]
    return row


# --- the bearing (signatelec.config.bearing) ---------------------------------------------------

_POSITIVE = "must be a finite number > 0"
_BETWEEN = "must be a finite number in [{low:g}, {high:g}]"

BEARING = (
    Constraint("bearing", "name", STRING),
    Constraint(
        "bearing", "n_balls", INTEGER, 3, 10_000, allowed="must be an integer >= 3 and <= {high}"
    ),
    *(
        Constraint("bearing", key, NUMBER, low=0.0, low_open=True, allowed=_POSITIVE)
        for key in (
            "outer_race_radius_m",
            "inner_race_radius_m",
            "outer_groove_radius_m",
            "inner_groove_radius_m",
            "ball_radius_m",
            "cage_ball_radius_m",
            "dynamic_load_rating_n",
            "inner_ring_mass_kg",
            "electrical_conductivity_s_m",
            "pocket_clearance_m",
        )
    ),
    Constraint("bearing", "friction_coefficient", NUMBER, 0.0, 2.0, allowed=_BETWEEN),
    Constraint(
        "bearing",
        "outer_race_radius_m",
        NUMBER,
        rule=Limit("zero_clearance_geometry"),
        allowed="must equal inner_race_radius_m + 2 ball_radius_m = "
        "{zero_clearance_outer_race_radius_m:.6g} m (zero-clearance geometry, seed eq. 14); set "
        "a clearance or preload with clearance_m",
    ),
    *(
        Constraint(
            "bearing",
            key,
            NUMBER,
            low=Limit("ball_radius_m"),
            low_open=True,
            allowed="must exceed ball_radius_m = {low:g} m (deep groove, seed 2.2)",
        )
        for key in ("inner_groove_radius_m", "outer_groove_radius_m")
    ),
    # balls and cage balls alternate on the pitch circle: neighbours 2 pi / (2 Z) apart
    Constraint(
        "bearing",
        "n_balls",
        INTEGER,
        rule=Limit("balls_fit"),
        allowed="{value} balls of radius {ball_radius_m:g} m and cage balls of radius "
        "{cage_ball_radius_m:g} m do not fit on the pitch circle of radius {pitch_radius_m:g} m "
        "(need 2 r_p sin(pi/2Z) >= R_b + R_c)",
    ),
    Constraint(
        "bearing",
        "cage_ball_radius_m",
        NUMBER,
        high=Limit("ball_radius_m"),
        high_open=True,
        allowed="must be smaller than ball_radius_m",
    ),
    Constraint(
        "bearing",
        "pocket_clearance_m",
        NUMBER,
        high=Limit("ball_radius_m"),
        allowed="must be at most ball_radius_m = {high:g} m (a ball's play in its cage pocket)",
    ),
)

#: A material's fields (keys printed as ``bearing.ball_material.<field>``).
MATERIAL = (
    Constraint("material", "name", STRING),
    Constraint("material", "youngs_modulus_pa", NUMBER, 1e6, 1e13, allowed=_BETWEEN),
    Constraint("material", "poisson", NUMBER, 0.0, 0.4999, allowed=_BETWEEN),
    Constraint("material", "density_kg_m3", NUMBER, 1.0, 1e5, allowed=_BETWEEN),
)

# --- the scene (signatelec.config.scene) -------------------------------------------------------

#: Largest Hertz overlap, as a fraction of the ball radius, that a scene's static ball load may
#: ask for: half the 10 % at which the DEM stops (a sudden load overshoots ~1.6x in overlap).
OVERLAP_LIMIT_FRACTION = 0.05
#: Largest clearance or preload, as a fraction of the ball radius.
CLEARANCE_LIMIT_FRACTION = 0.05
#: Smallest time step: n_steps = duration_s / dt_s stays a 64-bit count (100 s / 1e-12 s = 1e14)
#: and far below any stability limit of the seed's contacts (~1e-6 s).
DT_MIN_S = 1e-12
DT_MAX_S = 1e-4
DURATION_MAX_S = 100.0

_OVERLAP_PERCENT = f"{100 * OVERLAP_LIMIT_FRACTION:g} % of the ball radius (Hertz)"

#: Ranges and physics rules of the scene keys, checked in this order after every key's type
#: (from its dataclass field: number, true/false or one of its choices).
SCENE = (
    Constraint("operating", "radial_load_n", NUMBER, low=0.0, allowed="must be >= 0 N"),
    Constraint("operating", "omega_rad_s", NUMBER, low=0.0, allowed="must be >= 0 rad/s"),
    Constraint(
        "operating",
        "radial_load_n",
        NUMBER,
        high=Limit("radial_load_limit_n"),
        allowed="must be <= {high:.4g} N: Stribeck's largest ball load 4.37 F_r / Z would "
        f"overlap a raceway by more than {_OVERLAP_PERCENT}",
    ),
    Constraint(
        "operating",
        "omega_rad_s",
        NUMBER,
        high=Limit("omega_limit_rad_s"),
        allowed="must be <= {high:.4g} rad/s: the centrifugal force of a ball would overlap the "
        f"outer raceway by more than {_OVERLAP_PERCENT}",
    ),
    Constraint(
        "operating",
        "injected_current_a",
        NUMBER,
        low=0.0,
        low_open=True,
        allowed="must be > 0 A",
    ),
    Constraint(
        "operating",
        "measurement_frequency_hz",
        NUMBER,
        low=0.0,
        low_open=True,
        high=1e9,
        allowed="must be in (0, 1e9] Hz",
    ),
    Constraint(
        "lubricant",
        "temperature_c",
        NUMBER,
        low=-30.0,
        high=150.0,
        allowed="must be in [-30, 150] C (ASTM D341's range for mineral and PAO oils)",
    ),
    *(
        Constraint("lubricant", key, NUMBER, low=0.0, allowed="must be >= 0 (0: the oil's value)")
        for key in (
            "viscosity_40c_mm2_s",
            "viscosity_100c_mm2_s",
            "density_kg_m3",
            "pressure_viscosity_1_pa",
            "relative_permittivity",
            "resistivity_ohm_m",
        )
    ),
    Constraint(
        "lubricant",
        "viscosity_100c_mm2_s",
        NUMBER,
        rule=Limit("viscosity_falls"),
        allowed="must be below the 40 C viscosity (ASTM D341: viscosity falls with temperature)",
    ),
    Constraint(
        "lubricant",
        "relative_permittivity",
        NUMBER,
        rule=Limit("permittivity_physical"),
        allowed="must be 0 (the oil's) or >= 1",
    ),
    *(
        Constraint("lubricant", key, NUMBER, low=0.0, low_open=True, allowed="must be > 0 m")
        for key in ("ball_roughness_m", "race_roughness_m", "meniscus_gap_m")
    ),
    Constraint(
        "operating",
        "clearance_m",
        NUMBER,
        low=Limit("clearance_limit_m", -1.0),
        high=Limit("clearance_limit_m"),
        allowed="must be within +-{high:.3g} m "
        f"({100 * CLEARANCE_LIMIT_FRACTION:g} % of the ball radius)",
    ),
    Constraint(
        "operating",
        "clearance_m",
        NUMBER,
        low=Limit("preload_limit_m", -1.0),
        allowed="a preload beyond {low:.3g} m loads the balls past the 4.2 GPa static contact "
        "pressure limit (ISO 76)",
    ),
    *(
        Constraint("procedure", key, NUMBER, low=0.0, allowed="must be >= 0 s")
        for key in ("clearance_time_s", "load_time_s", "spin_up_time_s")
    ),
    Constraint("numerics", "dt_s", NUMBER, low=0.0, low_open=True, allowed="must be > 0 s"),
    Constraint(
        "numerics",
        "dt_s",
        NUMBER,
        low=DT_MIN_S,
        allowed=f"must be >= {DT_MIN_S:g} s (the time loop counts its steps in 64 bits)",
    ),
    Constraint("numerics", "dt_s", NUMBER, high=DT_MAX_S, allowed=f"must be <= {DT_MAX_S:g} s"),
    Constraint(
        "numerics",
        "duration_s",
        NUMBER,
        low=Limit("setup_time_s"),
        low_open=True,
        allowed="must exceed the set-up phases (clearance + load + spin-up = {low:g} s)",
    ),
    Constraint(
        "numerics",
        "duration_s",
        NUMBER,
        high=DURATION_MAX_S,
        allowed=f"must be <= {DURATION_MAX_S:g} s",
    ),
    Constraint(
        "numerics",
        "sample_rate_hz",
        NUMBER,
        low=0.0,
        low_open=True,
        high=Limit("sample_rate_limit_hz"),
        allowed="must be in (0, 1/dt_s = {high:g}] Hz",
    ),
    Constraint(
        "numerics",
        "sample_rate_hz",
        NUMBER,
        low=Limit("sample_rate_floor_hz"),
        allowed="must be >= 1/duration_s = {low:g} Hz (one recorded sample at least)",
    ),
    Constraint(
        "numerics",
        "linear_stiffness_n_m",
        NUMBER,
        low=0.0,
        allowed="must be >= 0 N/m (0: Hertz secant stiffness)",
    ),
)

# --- the dataset spec (signatelec.data.spec) ---------------------------------------------------

DESIGN_KINDS = ("grid", "random", "latin_hypercube")
#: Factors a design may vary. radial_load_n | radial_load_fraction (of C_r) and
#: clearance_m | epsilon (seed eq. 15, solved quasi-statically for the clearance) exclude each
#: other; a factor not given keeps the base scene's value. ``condition`` (text levels of
#: :data:`CONDITIONS`) puts one spall of ``spall_length_m`` by ``spall_depth_m`` at
#: ``spall_angle_rad`` on the outer race, the inner race or ball 0, or an unbalance of
#: ``unbalance_force_n`` at ``unbalance_phase_rad`` (signatelec.config.defects).
FACTORS = (
    "radial_load_n",
    "radial_load_fraction",
    "clearance_m",
    "epsilon",
    "omega_rad_s",
    "initial_ball_angle_rad",
    "condition",
    "spall_length_m",
    "spall_depth_m",
    "spall_angle_rad",
    "unbalance_force_n",
    "unbalance_phase_rad",
)
#: The condition of a bearing without a defect or an abnormal load.
HEALTHY = "healthy"
#: The conditions of a bearing a dataset labels and the condition model tells apart.
CONDITIONS = (HEALTHY, "outer", "inner", "ball", "unbalance")
#: Largest target epsilon a spec may ask for (a preload; at small loads epsilon grows fast).
EPSILON_MAX = 20.0
MAX_TRACES = 1_000_000
MAX_GRID_LEVELS = 10_000
SCALES = ("linear", "log")

#: The simulated signals a dataset may measure: the resistance, or the lubricated bearing's
#: capacitance or impedance (``effects.lubrication = "ehl"``).
SIGNALS = ("resistance_ohm", "capacitance_f", "impedance_ohm")

DATASET = (
    Constraint("dataset", "name", STRING),
    Constraint("dataset", "description", STRING),
    Constraint("dataset", "seed", INTEGER, 0, 2**63 - 1),
    Constraint("dataset", "fidelity", CHOICE, choices=Limit("fidelities")),
    Constraint("dataset", "duration_s", NUMBER, 0.0, 10.0, low_open=True),
    Constraint("dataset", "settle_s", NUMBER, 0.0, 10.0),
    Constraint("dataset", "signal", CHOICE, choices=SIGNALS),
)

DESIGN = (
    Constraint("design", "kind", CHOICE, choices=DESIGN_KINDS),
    Constraint("design", "n_traces", INTEGER, 1, MAX_TRACES),
)

#: The numbers of a factor (``value``, each of ``values``, ``min``, ``max``); the scene's own
#: rules then apply to each (load, clearance and speed limits), and to epsilon its range.
FACTOR = (
    Constraint("factor", "number", NUMBER),
    Constraint("factor", "condition", CHOICE, choices=CONDITIONS),
    Constraint("factor", "levels", INTEGER, 1, MAX_GRID_LEVELS),
    Constraint("factor", "scale", CHOICE, choices=SCALES),
    Constraint(
        "factor",
        "epsilon",
        NUMBER,
        low=0.0,
        low_open=True,
        high=EPSILON_MAX,
        allowed=f"must be in (0, {EPSILON_MAX:g}]: 0 < epsilon < 0.5 a clearance, 0.5 none, "
        "> 0.5 a preload",
    ),
)

#: Every key of the measurement model (signatelec.measurement.model.MeasurementModel).
MEASUREMENT = (
    Constraint("measurement", "sample_rate_hz", NUMBER, 0.0, 1e6, low_open=True),
    Constraint("measurement", "oversample", INTEGER, 1, 64),
    Constraint("measurement", "anti_alias", BOOLEAN),
    Constraint("measurement", "anti_alias_order", INTEGER, 1, 16),
    Constraint(
        "measurement",
        "anti_alias_cutoff",
        NUMBER,
        0.0,
        1.0,
        low_open=True,
        high_open=True,
        allowed="must be in (0, 1): a fraction of the output Nyquist frequency",
    ),
    Constraint("measurement", "noise_fraction", INTERVAL, 0.0, 1.0),
    Constraint("measurement", "drift_fraction", INTERVAL, 0.0, 1.0),
    Constraint("measurement", "offset_ohm", INTERVAL, -1.0, 1.0),
    Constraint("measurement", "quantisation_ohm", NUMBER, 0.0, 0.01),
)
