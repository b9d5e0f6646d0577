"""A dataset spec: reading and checking it, the designs it asks for, what its traces share.

The format is documented in ``datasets/README.md``; in short (TOML; ``[dataset]``, one or more
``[[design]]`` blocks, ``[measurement]``, ``[scene]``)::

    [dataset]
    name = "small"
    seed = 20240605                 # root seed, 0 <= seed < 2**63
    fidelity = "dem"                # quasistatic | dem | fast | balanced | reference
    duration_s = 0.05               # recorded steady window per trace, s
    settle_s = 0.03                 # steady time skipped after the set-up, s

    [[design]]
    kind = "latin_hypercube"        # grid | random | latin_hypercube
    n_traces = 16                   # random / latin_hypercube (grid: product of the levels)
    factors.radial_load_fraction = {min = 0.1, max = 0.4}    # F_r / C_r (or radial_load_n)
    factors.epsilon = {min = 0.3, max = 0.49}                # target eps (or clearance_m)
    factors.omega_rad_s = {value = 500.0}

    [measurement]
    sample_rate_hz = 10000.0
    noise_fraction = [0.001, 0.01]  # number or [low, high], drawn per trace
    ...

    [scene.procedure]               # base scene, Scene TOML layout
    spin_up_time_s = 0.01

A factor is ``{value = x}`` (constant), ``{values = [...]}`` (levels; random and Latin hypercube
designs pick among them) or ``{min, max}`` (with ``levels = k`` in a grid, optional
``scale = "log"``). Every value is checked by the rows of :mod:`signatelec.config.constraints`
(``DATASET``, ``DESIGN``, ``FACTOR``, ``MEASUREMENT``) and each factor value by the base
scene's own rules, so a spec that passes asks for no scene that is not allowed.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from signatelec.config.constraints import (
    DATASET,
    DESIGN,
    FACTOR,
    FACTORS,
    MAX_TRACES,
    MEASUREMENT,
    Checker,
    row_of,
)
from signatelec.config.defects import Defect
from signatelec.config.scene import Scene, SceneError, read_toml
from signatelec.measurement.model import MeasurementModel

#: Steady time a DEM trace skips after the set-up when the spec gives none, s: the ring and
#: cage settle after the spin-up. Over 16 fast-DEM runs of four bearings (0.05-0.4 C_r,
#: 0-15 um, 200-700 rad/s) the mean resistance of the 50 ms after 2 ms of settling reads
#: 0.001-0.24 % low (-0.09 % on average; F_r 3/4 of that high, R ~ F_r^(-4/3)), after 30 ms
#: within 0.033 %; the cost, 28 ms more of simulated time per trace (a 50 ms trace and its
#: ~7 ms set-up: +47 %). The quasi-static tier has no transient: 0 there.
SETTLE_S = 0.03
#: A spall's size when the design gives none: the example of the scene format's ``[[defects]]``
#: (signatelec.config.defects), m.
DEFAULT_SPALL_LENGTH_M = 1.5e-3
DEFAULT_SPALL_DEPTH_M = 50e-6


def spall_of(
    location: str,
    length_m: float = DEFAULT_SPALL_LENGTH_M,
    depth_m: float = DEFAULT_SPALL_DEPTH_M,
    angle_rad: float = 0.0,
) -> Defect:
    """One rectangular spall on the outer race, the inner race or ball 0."""
    return Defect(location=location, angle_rad=angle_rad, length_m=length_m, depth_m=depth_m)


class SpecError(ValueError):
    """A spec value that is not allowed: ``spec 'PATH': key = value: what is allowed``."""


@dataclass(frozen=True)
class Factor:
    """One design factor: a constant, a set of levels or a range."""

    name: str
    kind: str  # "value" | "values" | "range"
    values: tuple[float, ...] = ()
    low: float = math.nan
    high: float = math.nan
    levels: int | None = None
    scale: str = "linear"

    def grid_levels(self) -> list[float]:
        if self.kind != "range":
            return list(self.values)
        if self.scale == "log":
            return list(np.geomspace(self.low, self.high, self.levels))
        return list(np.linspace(self.low, self.high, self.levels))

    def from_unit(self, u: float) -> float:
        """The factor's value at the point u in [0, 1) of its unit interval."""
        if self.kind == "value":
            return self.values[0]
        if self.kind == "values":
            return self.values[min(int(u * len(self.values)), len(self.values) - 1)]
        if self.scale == "log":
            return float(self.low * (self.high / self.low) ** u)
        return float(self.low + (self.high - self.low) * u)

    def to_dict(self) -> dict:
        if self.kind == "value":
            return {"value": self.values[0]}
        if self.kind == "values":
            return {"values": list(self.values)}
        d: dict[str, Any] = {"min": self.low, "max": self.high, "scale": self.scale}
        if self.levels is not None:
            d["levels"] = self.levels
        return d


@dataclass(frozen=True)
class DesignBlock:
    kind: str
    n_traces: int
    factors: tuple[Factor, ...]

    def to_dict(self) -> dict:
        return {
            "kind": self.kind,
            "n_traces": self.n_traces,
            "factors": {f.name: f.to_dict() for f in self.factors},
        }


@dataclass(frozen=True)
class TraceContext:
    """What every trace of a dataset shares (sent to the workers with each trace)."""

    scene: Scene
    fidelity: str
    duration_s: float
    settle_s: float
    measurement: MeasurementModel
    root_seed: int
    #: Some trace has a target epsilon (the workers then import the quasi-static solver).
    needs_epsilon: bool = False
    #: The simulated signal measured (a column of the run's ``signals`` table).
    signal: str = "resistance_ohm"


@dataclass(frozen=True)
class Spec:
    path: str
    name: str
    description: str
    seed: int
    fidelity: str
    duration_s: float
    settle_s: float
    signal: str
    designs: tuple[DesignBlock, ...]
    measurement: MeasurementModel
    scene: Scene
    scene_table: dict = field(default_factory=dict, compare=False)

    @property
    def n_traces(self) -> int:
        return sum(b.n_traces for b in self.designs)

    @property
    def context(self) -> TraceContext:
        needs_epsilon = any(f.name == "epsilon" for b in self.designs for f in b.factors)
        return TraceContext(
            self.scene,
            self.fidelity,
            self.duration_s,
            self.settle_s,
            self.measurement,
            self.seed,
            needs_epsilon,
            self.signal,
        )

    def to_dict(self) -> dict:
        """The normalised spec (defaults filled in); JSON-able; identifies the dataset."""
        m = asdict(self.measurement)
        for key in ("noise_fraction", "drift_fraction", "offset_ohm"):
            m[key] = list(m[key])
        return {
            "dataset": {
                "name": self.name,
                "description": self.description,
                "seed": self.seed,
                "fidelity": self.fidelity,
                "duration_s": self.duration_s,
                "settle_s": self.settle_s,
                # named only when not the resistance: a spec of earlier releases keeps its identity
                **({"signal": self.signal} if self.signal != "resistance_ohm" else {}),
            },
            "design": [b.to_dict() for b in self.designs],
            "measurement": m,
            "scene": self.scene_table,
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)


_TOP_KEYS = ("dataset", "design", "measurement", "scene")
_DESIGN_KEYS = ("kind", "n_traces", "factors")
_FACTOR_KEYS = ("value", "values", "min", "max", "levels", "scale")
#: Scene keys the dataset sets itself, with where to set them instead.
_SCENE_RESERVED = {
    ("numerics", "duration_s"): "set by [dataset] duration_s and settle_s",
    ("numerics", "sample_rate_hz"): "set by [measurement] sample_rate_hz and oversample",
    ("numerics", "fidelity"): "set by [dataset] fidelity",
    ("outputs", "electrical"): "the dataset needs the resistance; the electrical output stays on",
}
_NUMBER = row_of(FACTOR, "factor", "number")
_EPSILON = row_of(FACTOR, "factor", "epsilon")
_CONDITION = row_of(FACTOR, "factor", "condition")


def load_spec(path: str | Path) -> Spec:
    """Read and validate a dataset spec; :class:`SpecError` names the first bad value."""
    path_s = str(path)
    return spec_from_dict(read_toml(path, f"spec {path_s!r}", "a spec", SpecError), path_s)


def spec_from_dict(data: dict, path: str = "<spec>") -> Spec:
    from signatelec.engines.fidelity import FIDELITY_NAMES

    check = Checker(SpecError, f"spec {path!r}", limits={"fidelities": FIDELITY_NAMES})
    check.keys("", data, _TOP_KEYS)

    ds = check.table("dataset", data.get("dataset", {}))
    check.keys("dataset", ds, [row.key for row in DATASET])
    defaults = {
        "name": Path(path).stem,
        "description": "",
        "seed": 0,
        "fidelity": "dem",
        "duration_s": 0.05,
        # the DEM's ring and cage settle after the set-up; the quasi-static tier starts steady
        "settle_s": 0.0 if ds.get("fidelity") == "quasistatic" else SETTLE_S,
        "signal": "resistance_ohm",
    }
    dataset = {row.key: check.check(row, ds.get(row.key, defaults[row.key])) for row in DATASET}

    measurement = _measurement(check, data.get("measurement", {}))
    if measurement.sample_rate_hz * dataset["duration_s"] < 1.0:
        check.fail(
            "measurement.sample_rate_hz",
            measurement.sample_rate_hz,
            f"at dataset.duration_s = {dataset['duration_s']:g} s the window holds no sample; "
            f"must be >= 1/duration_s = {1.0 / dataset['duration_s']:.4g} Hz",
        )
    scene, scene_table = _base_scene(check, data.get("scene", {}))
    if dataset["signal"] != "resistance_ohm":
        if scene.effects.lubrication == "none":
            check.fail(
                "dataset.signal",
                dataset["signal"],
                'is the lubricated bearing\'s: needs [scene.effects] lubrication = "ehl"',
            )
        if measurement.offset_ohm != (0.0, 0.0) or measurement.quantisation_ohm != 0.0:
            check.fail(
                "measurement.offset_ohm",
                [*measurement.offset_ohm, measurement.quantisation_ohm],
                f"offset_ohm and quantisation_ohm must be 0 when dataset.signal = "
                f"{dataset['signal']} (they are in ohm); noise and drift are fractions",
            )

    raw_designs = data.get("design")
    if raw_designs is None:
        check.fail("design", None, "at least one [[design]] block is needed")
    if isinstance(raw_designs, dict):
        raw_designs = [raw_designs]
    if not isinstance(raw_designs, list) or not raw_designs:
        check.fail("design", raw_designs, "must be one or more [[design]] tables")
    designs = tuple(_design(check, f"design[{i}]", d, scene) for i, d in enumerate(raw_designs))
    total = sum(b.n_traces for b in designs)
    if total > MAX_TRACES:
        check.fail("design", total, f"the blocks ask for {total} traces; at most {MAX_TRACES}")
    return Spec(
        path=path,
        **dataset,
        designs=designs,
        measurement=measurement,
        scene=scene,
        scene_table=scene_table,
    )


def _measurement(check: Checker, raw: Any) -> MeasurementModel:
    m = check.table("measurement", raw)
    check.keys("measurement", m, [row.key for row in MEASUREMENT])
    default = MeasurementModel()
    values = {}
    for row in MEASUREMENT:
        fallback = getattr(default, row.key)
        fallback = list(fallback) if isinstance(fallback, tuple) else fallback  # an interval
        values[row.key] = check.check(row, m.get(row.key, fallback))
    return MeasurementModel(**values)


def _base_scene(check: Checker, raw: Any) -> tuple[Scene, dict]:
    table = check.table("scene", raw)
    for section, value in table.items():
        if isinstance(value, dict):
            for key, v in value.items():
                if (section, key) in _SCENE_RESERVED:
                    check.fail(f"scene.{section}.{key}", v, _SCENE_RESERVED[(section, key)])
    data = {s: dict(v) if isinstance(v, dict) else v for s, v in table.items()}
    numerics = data.setdefault("numerics", {})
    if isinstance(numerics, dict):
        numerics["duration_s"] = 99.0  # placeholder: each trace sets its own duration
    try:
        scene = Scene.from_dict(data)
    except SceneError as exc:
        raise SpecError(f"{check.where}: scene.{exc}") from None
    return scene, table


def _design(check: Checker, key: str, raw: Any, scene: Scene) -> DesignBlock:
    d = check.table(key, raw)
    check.keys(key, d, _DESIGN_KEYS)
    kind = check.check(row_of(DESIGN, "design", "kind"), d.get("kind", "grid"), f"{key}.kind")
    raw_factors = check.table(f"{key}.factors", d.get("factors", {}))
    factors = []
    for name, spec in raw_factors.items():
        fkey = f"{key}.factors.{name}"
        if name not in FACTORS:
            check.fail(fkey, spec, f"unknown factor; allowed: {', '.join(FACTORS)}")
        factors.append(_factor(check, fkey, name, spec, kind, scene))
    names = {f.name for f in factors}
    for a, b in (("radial_load_n", "radial_load_fraction"), ("clearance_m", "epsilon")):
        if a in names and b in names:
            check.fail(f"{key}.factors.{b}", raw_factors[b], f"give {a} or {b}, not both")
    n_traces = row_of(DESIGN, "design", "n_traces")
    if kind == "grid":
        count = math.prod(len(f.grid_levels()) for f in factors)
        if "n_traces" in d:
            n = check.check(n_traces, d["n_traces"], f"{key}.n_traces")
            if n != count:
                check.fail(
                    f"{key}.n_traces", n, f"a grid has the product of its levels, {count}, traces"
                )
    else:
        if "n_traces" not in d:
            check.fail(f"{key}.n_traces", None, f"a {kind} design needs n_traces >= 1")
        count = check.check(n_traces, d["n_traces"], f"{key}.n_traces")
    return DesignBlock(kind=kind, n_traces=count, factors=tuple(factors))


def _factor(check: Checker, key: str, name: str, raw: Any, kind: str, scene: Scene) -> Factor:
    if not isinstance(raw, dict):
        check.fail(key, raw, "must be a table: {value = x}, {values = [...]} or {min, max}")
    check.keys(key, raw, _FACTOR_KEYS)
    forms = [k for k in ("value", "values", "min") if k in raw]
    if len(forms) != 1 or ("max" in raw) != ("min" in raw):
        check.fail(key, raw, "must give exactly one of value, values, or min and max")
    if "levels" in raw and (kind != "grid" or "min" not in raw):
        check.fail(f"{key}.levels", raw["levels"], "only for a min/max range in a grid design")
    if "scale" in raw and "min" not in raw:
        check.fail(f"{key}.scale", raw["scale"], "only for a min/max range")
    if name == "condition":
        return _condition_factor(check, key, raw)
    if "value" in raw:
        factor = Factor(name, "value", (check.check(_NUMBER, raw["value"], f"{key}.value"),))
        checked = [(f"{key}.value", factor.values[0])]
    elif "values" in raw:
        values = raw["values"]
        if not isinstance(values, list) or not values:
            check.fail(f"{key}.values", values, "must be a non-empty array of numbers")
        vals = tuple(check.check(_NUMBER, v, f"{key}.values[{i}]") for i, v in enumerate(values))
        factor = Factor(name, "values", vals)
        checked = [(f"{key}.values[{i}]", v) for i, v in enumerate(vals)]
    else:
        lo = check.check(_NUMBER, raw["min"], f"{key}.min")
        hi = check.check(_NUMBER, raw["max"], f"{key}.max")
        if hi < lo:
            check.fail(f"{key}.max", hi, f"must be >= min = {lo:g}")
        scale_row = row_of(FACTOR, "factor", "scale")
        scale = check.check(scale_row, raw.get("scale", "linear"), f"{key}.scale")
        if scale == "log" and lo <= 0.0:
            check.fail(f"{key}.min", lo, "must be > 0 for scale = 'log'")
        levels = None
        if kind == "grid":
            if "levels" not in raw:
                check.fail(f"{key}.levels", None, "a min/max range in a grid needs levels >= 1")
            levels_row = row_of(FACTOR, "factor", "levels")
            levels = check.check(levels_row, raw["levels"], f"{key}.levels")
        factor = Factor(name, "range", (), lo, hi, levels, scale)
        checked = [(f"{key}.min", lo), (f"{key}.max", hi)]
    for where, value in checked:
        _check_factor_value(check, where, name, value, scene)
    return factor


def _condition_factor(check: Checker, key: str, raw: dict) -> Factor:
    """The ``condition`` factor: text levels among CONDITIONS (a value or values only)."""
    if "min" in raw:
        check.fail(key, raw, "a condition takes {value = ...} or {values = [...]}, not a range")
    values = [raw["value"]] if "value" in raw else raw["values"]
    if not isinstance(values, list) or not values:
        check.fail(f"{key}.values", values, "must be a non-empty array of conditions")
    where = f"{key}.value" if "value" in raw else f"{key}.values"
    vals = tuple(
        check.check(_CONDITION, v, where if "value" in raw else f"{where}[{i}]")
        for i, v in enumerate(values)
    )
    return Factor("condition", "value" if "value" in raw else "values", vals)


def _check_factor_value(check: Checker, key: str, name: str, value: float, scene: Scene) -> None:
    """The scene's own rule for the factor (load, clearance and speed limits; a spall's size
    on the bearing's surfaces, the unbalance within the load limit)."""
    if name == "epsilon":
        check.check(_EPSILON, value, key)
        return
    if name in ("initial_ball_angle_rad", "spall_angle_rad", "unbalance_phase_rad"):
        return
    if name in ("spall_length_m", "spall_depth_m"):
        size = {name.removeprefix("spall_"): value}
        for location in ("outer", "inner", "ball"):
            try:
                replace(scene, defects=(spall_of(location, **size),))
            except SceneError as exc:
                check.fail(key, value, str(exc).split(": ", 1)[-1])
        return
    if name == "radial_load_fraction":
        changes = {"radial_load_n": value * scene.bearing.dynamic_load_rating_n}
    else:
        changes = {name: value}
    try:
        scene.with_overrides(**changes)
    except SceneError as exc:
        rule = str(exc).split(": ", 1)[-1]
        if name == "radial_load_fraction":
            cr = scene.bearing.dynamic_load_rating_n
            rule = f"F_r = {value * cr:g} N (C_r = {cr:g} N): {rule}"
        check.fail(key, value, rule)
