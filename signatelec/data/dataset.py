"""Synthetic data: labelled resistance signatures at scale, written as Parquet (issue 5).

``signatelec generate SPEC.toml --out DIR`` (or :func:`generate`) expands the spec's design into
traces, simulates each trace's scene, applies the measurement model
(:mod:`signatelec.measurement.model`) and writes one small Parquet file per trace. The spec format
and
the output schema are documented in ``datasets/README.md``; in short:

Spec (TOML; ``[dataset]``, one or more ``[[design]]`` blocks, ``[measurement]``, ``[scene]``)::

    [dataset]
    name = "small"
    seed = 20240605                 # root seed, 0 <= seed < 2**63
    fidelity = "dem"                # quasistatic | dem | fast | balanced | reference
    duration_s = 0.05               # recorded steady window per trace, s
    settle_s = 0.002                # steady time skipped after the set-up, s

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
``scale = "log"``).

Seeds: trace ``i`` (its id, counted over all blocks) owns
``numpy.random.SeedSequence(seed).spawn(n)[i]``, i.e. ``SeedSequence(seed, spawn_key=(i,))``:
its child 0 draws the trace's factors in a random design, its child 1 every measurement random
number. A trace's noise therefore depends only on the root seed and its id, whatever the number
of traces, workers or the order they run in. A Latin hypercube, being joint, draws from
``SeedSequence(seed, spawn_key=(LHS_KEY, block))``.

Output: ``DIR/regime=<preload|zero|clearance>/trace-<id>.parquet``, one row per trace (labels
and the signals as list columns), each written under a temporary name and renamed; ``DIR`` is a
hive-partitioned dataset that pandas, pyarrow and dask read as is. ``DIR/_spec.json`` holds the
spec (written before the first trace), ``DIR/_manifest.json`` the summary (written last). The
trace ids done are those of the part files present: a rerun skips them, so a job killed at any
point resumes where it stopped.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import math
import os
import re
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from signatelec._version import __version__
from signatelec.config.scene import Scene, SceneError, read_toml
from signatelec.measurement.model import MeasurementError, MeasurementModel

#: Design kinds.
DESIGN_KINDS = ("grid", "random", "latin_hypercube")
#: Factors a design may vary. radial_load_n | radial_load_fraction (of C_r) and
#: clearance_m | epsilon (seed eq. 15, solved quasi-statically for the clearance) exclude each
#: other; a factor not given keeps the base scene's value.
FACTORS = (
    "radial_load_n",
    "radial_load_fraction",
    "clearance_m",
    "epsilon",
    "omega_rad_s",
    "initial_ball_angle_rad",
)
#: Regimes (the partition key): preload below -1 um, zero within +-1 um, clearance above.
REGIMES = ("preload", "zero", "clearance")
REGIME_TOLERANCE_M = 1e-6
#: Spawn-key word of the Latin-hypercube streams (trace streams use one-word keys (i,)).
LHS_KEY = 0x4C4853
#: Largest target epsilon a spec may ask for (a preload; at small loads epsilon grows fast).
EPSILON_MAX = 20.0
MAX_TRACES = 1_000_000
STATUS_OK, STATUS_FAILED = "ok", "failed"

PART_GLOB = "regime=*/trace-*.parquet"
_PART_NAME = re.compile(r"^trace-(\d+)\.parquet$")
SPEC_FILE = "_spec.json"
MANIFEST_FILE = "_manifest.json"
LOCK_FILE = ".lock"


class SpecError(ValueError):
    """A spec value that is not allowed: ``spec 'PATH': key = value: what is allowed``."""


class DatasetDirError(OSError):
    """The output directory cannot hold this dataset (another spec, not a dataset, in use)."""


class EpsilonError(ValueError):
    """No clearance gives the target epsilon at the trace's load and speed."""


# --- spec -------------------------------------------------------------------------------------


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


@dataclass(frozen=True)
class Spec:
    path: str
    name: str
    description: str
    seed: int
    fidelity: str
    duration_s: float
    settle_s: float
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
            },
            "design": [b.to_dict() for b in self.designs],
            "measurement": m,
            "scene": self.scene_table,
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) < 60 else text[:57] + "..."


class _Checker:
    """Raises SpecError in the one-line form ``spec 'PATH': key = value: rule``."""

    def __init__(self, path: str):
        self.path = path

    def fail(self, key: str, value: Any, rule: str) -> None:
        raise SpecError(f"spec {self.path!r}: {key} = {_short(value)}: {rule}")

    def table(self, key: str, value: Any) -> dict:
        if not isinstance(value, dict):
            self.fail(key, value, "must be a table")
        return value

    def keys(self, key: str, table: dict, allowed: tuple[str, ...]) -> None:
        for k, v in table.items():
            if k not in allowed:
                where = f"{key}.{k}" if key else k
                self.fail(where, v, f"unknown key; allowed: {', '.join(allowed)}")

    def number(self, key: str, value: Any, lo=-math.inf, hi=math.inf, *, lo_open=False) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.fail(key, value, "must be a number")
        if not math.isfinite(value):
            self.fail(key, value, "must be a finite number")
        if value < lo or (lo_open and value == lo) or value > hi:
            left = "(" if lo_open else "["
            self.fail(key, value, f"must be in {left}{lo:g}, {hi:g}]")
        return float(value)

    def integer(self, key: str, value: Any, lo: int, hi: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, value, "must be an integer")
        if not lo <= value <= hi:
            self.fail(key, value, f"must be an integer in [{lo}, {hi}]")
        return int(value)

    def string(self, key: str, value: Any, choices: tuple[str, ...] | None = None) -> str:
        if not isinstance(value, str) or (choices is not None and value not in choices):
            rule = f"must be one of {', '.join(choices)}" if choices else "must be a string"
            self.fail(key, value, rule)
        return value

    def boolean(self, key: str, value: Any) -> bool:
        if not isinstance(value, bool):
            self.fail(key, value, "must be true or false")
        return value

    def interval(self, key: str, value: Any, lo: float, hi: float) -> tuple[float, float]:
        """A number (fixed) or a [low, high] array (drawn uniformly per trace)."""
        if isinstance(value, list):
            if len(value) != 2:
                self.fail(key, value, "must be a number or a [low, high] array")
            a = self.number(f"{key}[0]", value[0], lo, hi)
            b = self.number(f"{key}[1]", value[1], lo, hi)
            if b < a:
                self.fail(key, value, "must be [low, high] with low <= high")
            return (a, b)
        x = self.number(key, value, lo, hi)
        return (x, x)


_TOP_KEYS = ("dataset", "design", "measurement", "scene")
_DATASET_KEYS = ("name", "description", "seed", "fidelity", "duration_s", "settle_s")
_DESIGN_KEYS = ("kind", "n_traces", "factors")
_FACTOR_KEYS = ("value", "values", "min", "max", "levels", "scale")
_MEASUREMENT_KEYS = tuple(MeasurementModel.__dataclass_fields__)
#: Scene keys the dataset sets itself, with where to set them instead.
_SCENE_RESERVED = {
    ("numerics", "duration_s"): "set by [dataset] duration_s and settle_s",
    ("numerics", "sample_rate_hz"): "set by [measurement] sample_rate_hz and oversample",
    ("numerics", "fidelity"): "set by [dataset] fidelity",
    ("outputs", "electrical"): "the dataset needs the resistance; the electrical output stays on",
}


def load_spec(path: str | Path) -> Spec:
    """Read and validate a dataset spec; :class:`SpecError` names the first bad value."""
    path_s = str(path)
    return spec_from_dict(read_toml(path, f"spec {path_s!r}", "a spec", SpecError), path_s)


def spec_from_dict(data: dict, path: str = "<spec>") -> Spec:
    check = _Checker(path)
    check.keys("", data, _TOP_KEYS)

    ds = check.table("dataset", data.get("dataset", {}))
    check.keys("dataset", ds, _DATASET_KEYS)
    name = check.string("dataset.name", ds.get("name", Path(path).stem))
    description = check.string("dataset.description", ds.get("description", ""))
    seed = check.integer("dataset.seed", ds.get("seed", 0), 0, 2**63 - 1)
    from signatelec.engines.fidelity import FIDELITY_NAMES

    fidelity = check.string("dataset.fidelity", ds.get("fidelity", "dem"), FIDELITY_NAMES)
    duration = check.number(
        "dataset.duration_s", ds.get("duration_s", 0.05), 0.0, 10.0, lo_open=True
    )
    settle = check.number("dataset.settle_s", ds.get("settle_s", 2e-3), 0.0, 10.0)

    measurement = _measurement(check, data.get("measurement", {}))
    scene, scene_table = _base_scene(check, data.get("scene", {}))

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
        name=name,
        description=description,
        seed=seed,
        fidelity=fidelity,
        duration_s=duration,
        settle_s=settle,
        designs=designs,
        measurement=measurement,
        scene=scene,
        scene_table=scene_table,
    )


def _measurement(check: _Checker, raw: Any) -> MeasurementModel:
    m = check.table("measurement", raw)
    check.keys("measurement", m, _MEASUREMENT_KEYS)
    d = MeasurementModel()
    key = "measurement."
    fs = check.number(
        key + "sample_rate_hz", m.get("sample_rate_hz", d.sample_rate_hz), 0, 1e6, lo_open=True
    )
    return MeasurementModel(
        sample_rate_hz=fs,
        oversample=check.integer(key + "oversample", m.get("oversample", d.oversample), 1, 64),
        anti_alias=check.boolean(key + "anti_alias", m.get("anti_alias", d.anti_alias)),
        anti_alias_order=check.integer(
            key + "anti_alias_order", m.get("anti_alias_order", d.anti_alias_order), 1, 16
        ),
        anti_alias_cutoff=_open_unit(
            check, key + "anti_alias_cutoff", m.get("anti_alias_cutoff", d.anti_alias_cutoff)
        ),
        noise_fraction=check.interval(
            key + "noise_fraction", m.get("noise_fraction", 0.0), 0.0, 1.0
        ),
        drift_fraction=check.interval(
            key + "drift_fraction", m.get("drift_fraction", 0.0), 0.0, 1.0
        ),
        offset_ohm=check.interval(key + "offset_ohm", m.get("offset_ohm", 0.0), -1.0, 1.0),
        quantisation_ohm=check.number(
            key + "quantisation_ohm", m.get("quantisation_ohm", 0.0), 0.0, 0.01
        ),
    )


def _open_unit(check: _Checker, key: str, value: Any) -> float:
    x = check.number(key, value)
    if not 0.0 < x < 1.0:
        check.fail(key, value, "must be in (0, 1): a fraction of the output Nyquist frequency")
    return x


def _base_scene(check: _Checker, raw: Any) -> tuple[Scene, dict]:
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
        raise SpecError(f"spec {check.path!r}: scene.{exc}") from None
    return scene, table


def _design(check: _Checker, key: str, raw: Any, scene: Scene) -> DesignBlock:
    d = check.table(key, raw)
    check.keys(key, d, _DESIGN_KEYS)
    kind = check.string(f"{key}.kind", d.get("kind", "grid"), DESIGN_KINDS)
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
    if kind == "grid":
        count = math.prod(len(f.grid_levels()) for f in factors)
        if "n_traces" in d:
            n = check.integer(f"{key}.n_traces", d["n_traces"], 1, MAX_TRACES)
            if n != count:
                check.fail(
                    f"{key}.n_traces", n, f"a grid has the product of its levels, {count}, traces"
                )
    else:
        if "n_traces" not in d:
            check.fail(f"{key}.n_traces", None, f"a {kind} design needs n_traces >= 1")
        count = check.integer(f"{key}.n_traces", d["n_traces"], 1, MAX_TRACES)
    return DesignBlock(kind=kind, n_traces=count, factors=tuple(factors))


def _factor(check: _Checker, key: str, name: str, raw: Any, kind: str, scene: Scene) -> Factor:
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
    if "value" in raw:
        factor = Factor(name, "value", (check.number(f"{key}.value", raw["value"]),))
        checked = [(f"{key}.value", factor.values[0])]
    elif "values" in raw:
        values = raw["values"]
        if not isinstance(values, list) or not values:
            check.fail(f"{key}.values", values, "must be a non-empty array of numbers")
        vals = tuple(check.number(f"{key}.values[{i}]", v) for i, v in enumerate(values))
        factor = Factor(name, "values", vals)
        checked = [(f"{key}.values[{i}]", v) for i, v in enumerate(vals)]
    else:
        lo = check.number(f"{key}.min", raw["min"])
        hi = check.number(f"{key}.max", raw["max"])
        if hi < lo:
            check.fail(f"{key}.max", hi, f"must be >= min = {lo:g}")
        scale = check.string(f"{key}.scale", raw.get("scale", "linear"), ("linear", "log"))
        if scale == "log" and lo <= 0.0:
            check.fail(f"{key}.min", lo, "must be > 0 for scale = 'log'")
        levels = None
        if kind == "grid":
            if "levels" not in raw:
                check.fail(f"{key}.levels", None, "a min/max range in a grid needs levels >= 1")
            levels = check.integer(f"{key}.levels", raw["levels"], 1, 10000)
        factor = Factor(name, "range", (), lo, hi, levels, scale)
        checked = [(f"{key}.min", lo), (f"{key}.max", hi)]
    for where, value in checked:
        _check_factor_value(check, where, name, value, scene)
    return factor


def _check_factor_value(check: _Checker, key: str, name: str, value: float, scene: Scene) -> None:
    """The scene's own rule for the factor (load, clearance and speed limits)."""
    if name == "epsilon":
        if not 0.0 < value <= EPSILON_MAX:
            check.fail(
                key,
                value,
                f"must be in (0, {EPSILON_MAX:g}]: 0 < epsilon < 0.5 a clearance, 0.5 none, "
                "> 0.5 a preload",
            )
        return
    if name == "initial_ball_angle_rad":
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


# --- design -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class TraceTask:
    """One trace to simulate: its id, design block and factor values."""

    trace_id: int
    block: int
    values: tuple[tuple[str, float], ...]

    @property
    def factors(self) -> dict[str, float]:
        return dict(self.values)


def trace_seed_sequence(root_seed: int, trace_id: int) -> np.random.SeedSequence:
    """``SeedSequence(root_seed).spawn(n)[trace_id]`` for any n > trace_id."""
    return np.random.SeedSequence(root_seed, spawn_key=(trace_id,))


def trace_rng(root_seed: int, trace_id: int, stream: int) -> np.random.Generator:
    """Stream 0: the trace's design draws (random design); stream 1: its measurement."""
    return np.random.default_rng(trace_seed_sequence(root_seed, trace_id).spawn(2)[stream])


def design_traces(spec: Spec) -> list[TraceTask]:
    """Every trace of the spec, ids 0..n-1 over the blocks in order."""
    tasks: list[TraceTask] = []
    for block_index, block in enumerate(spec.designs):
        names = [f.name for f in block.factors]
        first = len(tasks)
        if block.kind == "grid":
            rows = list(itertools.product(*(f.grid_levels() for f in block.factors)))
        elif block.kind == "random":
            rows = []
            for k in range(block.n_traces):
                rng = trace_rng(spec.seed, first + k, 0)
                u = rng.random(len(block.factors))
                rows.append([f.from_unit(x) for f, x in zip(block.factors, u, strict=True)])
        else:
            from scipy.stats import qmc

            seq = np.random.SeedSequence(spec.seed, spawn_key=(LHS_KEY, block_index))
            d = max(len(block.factors), 1)
            sample = qmc.LatinHypercube(d=d, rng=np.random.default_rng(seq)).random(block.n_traces)
            rows = [
                [f.from_unit(x) for f, x in zip(block.factors, row, strict=False)] for row in sample
            ]
        for k, row in enumerate(rows):
            values = tuple((n, float(v)) for n, v in zip(names, row, strict=True))
            tasks.append(TraceTask(first + k, block_index, values))
    return tasks


# --- one trace --------------------------------------------------------------------------------


def regime_of(clearance_m: float) -> str:
    if clearance_m < -REGIME_TOLERANCE_M:
        return "preload"
    if clearance_m > REGIME_TOLERANCE_M:
        return "clearance"
    return "zero"


def clearance_for_epsilon(
    bearing, radial_load_n: float, omega_rad_s: float, epsilon: float
) -> float:
    """Radial clearance (m; < 0 a preload) whose quasi-static epsilon (seed eq. 15) is ``epsilon``.

    0 < epsilon < 0.5: :func:`signatelec.physics.quasistatic.clearance_for_epsilon` (a clearance);
    0.5: none;
    above 0.5 the same equilibrium (Hertz, centrifugal force and gravity, averaged over one ball
    spacing) solved for a preload, down to the static-pressure limit of
    :func:`signatelec.physics.quasistatic.preload_limit_m`. Raises :class:`EpsilonError`.
    """
    if epsilon == 0.5:
        return 0.0
    if 0.0 < epsilon < 0.5:
        from signatelec.physics.quasistatic import clearance_for_epsilon as positive

        try:
            return positive(bearing, radial_load_n, omega_rad_s, epsilon)
        except ValueError as exc:
            raise EpsilonError(
                f"epsilon = {epsilon:g}: no clearance up to 5 % of the ball radius gives it at "
                f"F_r = {radial_load_n:g} N ({exc})"
            ) from None
    from scipy.optimize import brentq

    from signatelec.physics.quasistatic import (
        ball_angles_rad,
        preload_limit_m,
        solve_equilibrium_over_time,
    )

    z = bearing.n_balls
    angles = ball_angles_rad(z, np.linspace(0.0, 2.0 * math.pi / z, 8, endpoint=False))

    def excess(clearance_m: float) -> float:
        state = solve_equilibrium_over_time(
            angles, bearing, radial_load_n, clearance_m, omega_rad_s, centrifugal=True, gravity=True
        )
        return float(np.mean(state.epsilon)) - epsilon

    lowest = -preload_limit_m(bearing)
    if excess(lowest) < 0.0:
        raise EpsilonError(
            f"epsilon = {epsilon:g}: beyond the largest preload ({lowest:.3g} m, 4.2 GPa) at "
            f"F_r = {radial_load_n:g} N, which gives {excess(lowest) + epsilon:.3g}"
        )
    return float(brentq(excess, lowest, 0.0, xtol=1e-10))


#: Label columns of a trace (the regime is the partition directory) and their Arrow types.
def _schema():
    import pyarrow as pa

    f64, i64, s = pa.float64(), pa.int64(), pa.string()
    return pa.schema(
        [
            ("trace_id", i64),
            ("design", pa.int32()),
            ("seed", i64),
            ("status", s),
            ("error", s),
            ("warnings", s),
            ("radial_load_n", f64),
            ("radial_load_fraction", f64),
            ("clearance_m", f64),
            ("epsilon", f64),
            ("epsilon_target", f64),
            ("omega_rad_s", f64),
            ("initial_ball_angle_rad", f64),
            ("fidelity", s),
            ("dt_s", f64),
            ("integrator", s),
            ("simulation_rate_hz", f64),
            ("sample_rate_hz", f64),
            ("duration_s", f64),
            ("t0_s", f64),
            ("n_samples", pa.int32()),
            ("noise_fraction", f64),
            ("drift_fraction", f64),
            ("offset_ohm", f64),
            ("quantisation_ohm", f64),
            ("resistance_mean_ohm", f64),
            ("delta_r_m", f64),
            ("max_ball_load_n", f64),
            ("ball_pass_frequency_hz", f64),
            ("cpu_s", f64),
            ("resistance_ohm", pa.list_(f64)),
            ("resistance_clean_ohm", pa.list_(f64)),
        ]
    )


def run_trace(ctx: TraceContext, task: TraceTask) -> dict:
    """Simulate one trace and measure it: a record of labels and signals (never raises for a
    scene that is not allowed, a divergence or an unreachable epsilon: those give status
    "failed" and the error)."""
    from signatelec.engines.fidelity import apply_fidelity
    from signatelec.engines.results import DivergenceError
    from signatelec.engines.simulate import simulate

    cpu0 = time.thread_time()
    f = task.factors
    base = ctx.scene
    b = base.bearing
    m = ctx.measurement
    cr = b.dynamic_load_rating_n
    if "radial_load_fraction" in f:
        load = f["radial_load_fraction"] * cr
    else:
        load = f.get("radial_load_n", base.operating.radial_load_n)
    omega = f.get("omega_rad_s", base.operating.omega_rad_s)
    target = f.get("epsilon", math.nan)
    clearance = f.get("clearance_m", base.operating.clearance_m)
    nan = math.nan
    rec: dict[str, Any] = {
        "trace_id": task.trace_id,
        "design": task.block,
        "seed": ctx.root_seed,
        "status": STATUS_OK,
        "error": "",
        "warnings": "",
        "radial_load_n": load,
        "radial_load_fraction": load / cr,
        "clearance_m": clearance if math.isnan(target) else nan,
        "epsilon": nan,
        "epsilon_target": target,
        "omega_rad_s": omega,
        "initial_ball_angle_rad": f.get(
            "initial_ball_angle_rad", base.operating.initial_ball_angle_rad
        ),
        "fidelity": ctx.fidelity,
        "dt_s": nan,
        "integrator": "",
        "simulation_rate_hz": nan,
        "sample_rate_hz": m.sample_rate_hz,
        "duration_s": ctx.duration_s,
        "t0_s": nan,
        "n_samples": 0,
        "noise_fraction": nan,
        "drift_fraction": nan,
        "offset_ohm": nan,
        "quantisation_ohm": m.quantisation_ohm,
        "resistance_mean_ohm": nan,
        "delta_r_m": nan,
        "max_ball_load_n": nan,
        "ball_pass_frequency_hz": b.ball_pass_frequency_hz(omega),
        "cpu_s": nan,
        "resistance_ohm": np.zeros(0),
        "resistance_clean_ohm": np.zeros(0),
    }
    # the regime from the design when the clearance cannot be had (epsilon: 0.5 is none)
    if math.isnan(target):
        rec["regime"] = regime_of(clearance)
    else:
        rec["regime"] = "zero" if target == 0.5 else ("clearance" if target < 0.5 else "preload")
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if not math.isnan(target):
                clearance = clearance_for_epsilon(b, load, omega, target)
                rec["clearance_m"] = clearance
                rec["regime"] = regime_of(clearance)
            scene = base.with_overrides(
                radial_load_n=load,
                clearance_m=clearance,
                omega_rad_s=omega,
                initial_ball_angle_rad=rec["initial_ball_angle_rad"],
            )
            scene = apply_fidelity(scene, ctx.fidelity)
            dt = scene.numerics.dt_s
            rec["dt_s"], rec["integrator"] = dt, scene.numerics.integrator
            n = int(round(ctx.duration_s * m.sample_rate_hz))
            t0 = scene.setup_time_s + ctx.settle_s + m.guard_s
            end = t0 + (n - 1) / m.sample_rate_hz + m.guard_s
            scene = scene.with_overrides(
                duration_s=end + 2.0 * dt, sample_rate_hz=m.simulation_rate_hz(dt)
            )
            rec["simulation_rate_hz"] = 1.0 / (scene.record_every * dt)
            rec["t0_s"], rec["n_samples"] = t0, n
            result = simulate(scene)
            sig = result.signals
            keep = sig["time_s"].to_numpy() >= t0 - m.guard_s - 1e-12
            clean = m.clean(
                sig["time_s"].to_numpy()[keep], sig["resistance_ohm"].to_numpy()[keep], t0, n
            )
            t = sig["time_s"].to_numpy()
            window = sig[(t >= t0 - 1e-12) & (t <= t0 + (n - 1) / m.sample_rate_hz + 1e-12)]
            rec["epsilon"] = float(window["epsilon"].mean())
            rec["delta_r_m"] = float(window["delta_r_m"].mean())
            rec["max_ball_load_n"] = float(window["max_ball_load_n"].mean())
            rng = trace_rng(ctx.root_seed, task.trace_id, 1)
            draw = m.draw(rng)
            rec["noise_fraction"] = draw.noise_fraction
            rec["drift_fraction"] = draw.drift_fraction
            rec["offset_ohm"] = draw.offset_ohm
            rec["resistance_clean_ohm"] = clean
            rec["resistance_mean_ohm"] = float(np.mean(clean))
            rec["resistance_ohm"] = m.measure(clean, draw, rng)
        messages = dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught)
        rec["warnings"] = " | ".join(messages)
    except (SceneError, DivergenceError, EpsilonError, MeasurementError) as exc:
        rec["status"] = STATUS_FAILED
        rec["error"] = f"{type(exc).__name__}: {exc}"
        rec["resistance_ohm"] = np.zeros(0)
        rec["resistance_clean_ohm"] = np.zeros(0)
    rec["cpu_s"] = time.thread_time() - cpu0
    return rec


# --- parts on disk ----------------------------------------------------------------------------


def part_path(out: Path, regime: str, trace_id: int) -> Path:
    return out / f"regime={regime}" / f"trace-{trace_id:06d}.parquet"


def done_trace_ids(out: str | Path) -> dict[int, Path]:
    """The manifest of finished traces: trace id -> part file, from the files present."""
    done: dict[int, Path] = {}
    for p in sorted(Path(out).glob(PART_GLOB)):
        match = _PART_NAME.match(p.name)
        if match:
            tid = int(match[1])
            if tid in done:
                raise DatasetDirError(f"trace {tid} is in both {done[tid]} and {p}")
            done[tid] = p
    return done


def trace_seed_json(root_seed: int, trace_id: int) -> dict:
    return {"entropy": root_seed, "spawn_key": [trace_id]}


def part_metadata(spec: Spec, trace_id: int | None = None) -> dict:
    """The schema metadata of a part file (``trace_seed`` filled in when trace_id is given)."""
    meta = {
        "version": __version__,
        "spec": spec.to_dict(),
        "root_seed": spec.seed,
        "seeding": (
            "trace i: numpy.random.SeedSequence(root_seed).spawn(n)[i] = "
            "SeedSequence(root_seed, spawn_key=(i,)); child 0 of it: design draws (random "
            "design), child 1: measurement; Latin hypercube block b: "
            f"SeedSequence(root_seed, spawn_key=({LHS_KEY}, b))"
        ),
    }
    if trace_id is not None:
        meta["trace_seed"] = trace_seed_json(spec.seed, trace_id)
    return meta


def record_table(rec: dict, metadata: dict):
    """A one-row Arrow table of a trace record, with the signatelec schema metadata."""
    import pyarrow as pa

    from signatelec.io import METADATA_KEY

    schema = _schema()
    arrays = []
    for fld in schema:
        value = rec[fld.name]
        if pa.types.is_list(fld.type):
            arrays.append(pa.array([np.asarray(value, dtype=float)], type=fld.type))
        else:
            arrays.append(pa.array([value], type=fld.type))
    meta = {METADATA_KEY: json.dumps(metadata).encode()}
    return pa.Table.from_arrays(arrays, schema=schema.with_metadata(meta))


def write_part(out: Path, rec: dict, metadata: dict) -> Path:
    """Write a trace's part file atomically (temporary name, fsync, rename)."""
    import pyarrow.parquet as pq

    path = part_path(out, rec["regime"], rec["trace_id"])
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            pq.write_table(record_table(rec, metadata), fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def _remove_stale_temporaries(out: Path) -> None:
    for pattern in (".*.tmp", "regime=*/.*.tmp"):
        for p in out.glob(pattern):
            with contextlib.suppress(OSError):
                p.unlink()


@contextlib.contextmanager
def _locked(out: Path) -> Iterator[None]:
    import fcntl

    with open(out / LOCK_FILE, "a") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise DatasetDirError(
                f"--out {str(out)!r}: another signatelec generate is writing there"
            ) from None
        yield


def prepare_output(spec: Spec, out: str | Path) -> Path:
    """Create ``out`` or check that it holds this spec's (partial) dataset."""
    out = Path(out)
    spec_path = out / SPEC_FILE
    if out.exists():
        if not out.is_dir():
            raise DatasetDirError(f"--out {str(out)!r}: exists and is not a directory")
        if spec_path.exists():
            try:
                stored = json.loads(spec_path.read_text(encoding="utf-8"))["spec"]
            except (OSError, ValueError, KeyError):
                stored = None
            if stored != json.loads(spec.to_json()):
                raise DatasetDirError(
                    f"--out {str(out)!r}: holds a dataset of another spec; choose another "
                    "directory (or remove it) to generate this one"
                )
            return out
        if any(not p.name.startswith(".") for p in out.iterdir()):  # .lock, temporaries
            raise DatasetDirError(
                f"--out {str(out)!r}: is not empty and holds no signatelec dataset; choose an "
                "empty or new directory"
            )
    out.mkdir(parents=True, exist_ok=True)
    _write_json(
        spec_path,
        {"version": __version__, "n_traces": spec.n_traces, "spec": json.loads(spec.to_json())},
    )
    return out


# --- warm-up and execution --------------------------------------------------------------------


def warm_up(ctx: TraceContext, *, imports: bool = True) -> float:
    """Compile (or load) the kernels the traces need by a tiny simulation of each effect set
    (the set-up phases plus a few recorded instants of the base scene at the spec's fidelity);
    with ``imports``, also import what a trace imports on first use (scipy.signal, the
    quasi-static solver of a target epsilon) so no trace pays for it.

    The kernel (signatelec.engines.dem.spec.KernelSpec) depends on the effects, the energy
    output, the bearing's friction and the fidelity's integrator, which every trace of a spec
    shares. Returns the seconds spent.
    """
    from signatelec.engines.fidelity import apply_fidelity
    from signatelec.engines.simulate import simulate

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = apply_fidelity(ctx.scene, ctx.fidelity)
        dt = scene.numerics.dt_s
        rate = min(1.0 / dt, 4.0 * ctx.measurement.sample_rate_hz)
        tiny = scene.with_overrides(
            duration_s=scene.setup_time_s + 40.0 / rate, sample_rate_hz=rate
        )
        result = simulate(tiny)
        if imports:
            sig = result.signals.tail(40)
            model = MeasurementModel(sample_rate_hz=rate / 4.0, anti_alias_order=2)
            t = sig["time_s"].to_numpy()
            with contextlib.suppress(MeasurementError):
                model.clean(t, sig["resistance_ohm"].to_numpy(), t[0], 8)
            if ctx.needs_epsilon:
                import signatelec.physics.quasistatic  # noqa: F401  (the clearance of an epsilon)
    return time.perf_counter() - t0


_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


#: State of a local worker process, set by its initializer.
_WORKER: dict[str, Any] = {}
#: Traces in flight per worker (bounded, so a million-trace spec is not queued at once).
IN_FLIGHT_PER_WORKER = 4
_SIGNALS = ("resistance_ohm", "resistance_clean_ohm")


def _worker_init(ctx: TraceContext, out: str, metadata: dict) -> None:
    """Each local worker, before its first trace: load the kernels the parent compiled."""
    _WORKER.update(ctx=ctx, out=Path(out), metadata=metadata)
    warm_up(ctx)


def _run_and_write(task: TraceTask) -> dict:
    """In a local worker: run the trace, write its part file, return its labels only."""
    rec = run_trace(_WORKER["ctx"], task)
    meta = {**_WORKER["metadata"], "trace_seed": trace_seed_json(rec["seed"], rec["trace_id"])}
    write_part(_WORKER["out"], rec, meta)
    return {k: v for k, v in rec.items() if k not in _SIGNALS}


def _process_context():
    """The start method of the local workers: a forkserver (started here, at once, so that its
    imports overlap the parent's kernel compilation) or, where there is none, spawn."""
    import multiprocessing
    import multiprocessing.forkserver

    for name in _THREAD_VARIABLES:  # one thread per worker: the workers are the parallelism
        os.environ.setdefault(name, "1")
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    mp = multiprocessing.get_context("forkserver")
    mp.set_forkserver_preload(["signatelec.data._forkserver_preload"])
    multiprocessing.forkserver.ensure_running()
    return mp


def _local_results(
    ctx: TraceContext, tasks: list[TraceTask], workers: int, out: Path, metadata: dict, mp=None
) -> Iterator[dict]:
    """Labels of each finished trace, whose part file is written (by the worker)."""
    if workers == 0:
        for task in tasks:
            rec = run_trace(ctx, task)
            meta = {**metadata, "trace_seed": trace_seed_json(rec["seed"], rec["trace_id"])}
            write_part(out, rec, meta)
            yield rec
        return
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    pool = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=mp or _process_context(),
        initializer=_worker_init,
        initargs=(ctx, str(out), metadata),
    )
    queue = iter(tasks)
    pending: set = set()
    with pool:
        try:
            while True:
                while len(pending) < IN_FLIGHT_PER_WORKER * workers:
                    task = next(queue, None)
                    if task is None:
                        break
                    pending.add(pool.submit(_run_and_write, task))
                if not pending:
                    break
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in finished:
                    yield fut.result()
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def _dask_results(
    ctx: TraceContext, tasks: list[TraceTask], client, out: Path, metadata: dict
) -> Iterator[dict]:
    """Labels of each finished trace; the cluster's workers return the records and this
    process writes the part files (the workers need not see ``out``)."""
    from distributed import as_completed

    client.run(warm_up, ctx)  # each worker loads (or compiles) the kernels once
    shared = client.scatter(ctx, broadcast=True)
    limit = IN_FLIGHT_PER_WORKER * max(sum(client.nthreads().values()), 1)
    queue = iter(tasks)
    running = as_completed()
    for task in itertools.islice(queue, limit):
        running.add(client.submit(run_trace, shared, task, pure=False))
    try:
        for fut in running:
            rec = fut.result()
            fut.release()
            meta = {**metadata, "trace_seed": trace_seed_json(rec["seed"], rec["trace_id"])}
            write_part(out, rec, meta)
            task = next(queue, None)
            if task is not None:
                running.add(client.submit(run_trace, shared, task, pure=False))
            yield rec
    finally:
        running.clear()


@dataclass
class Summary:
    out: str
    n_traces: int
    already_done: int
    generated: int
    failed_now: int
    failed_total: int
    wall_s: float
    warm_up_s: float
    cores: int
    cpu_s: float
    scheduler: str | None = None

    @property
    def traces_per_core_s(self) -> float:
        return self.generated / (self.wall_s * self.cores) if self.wall_s > 0 else math.nan

    def describe(self) -> str:
        where = f"Dask cluster {self.scheduler}" if self.scheduler else "local processes"
        lines = [
            f"traces: {self.n_traces} in the spec, {self.already_done} already present, "
            f"{self.generated} generated now",
            f"failures: {self.failed_now} now, {self.failed_total} in the dataset "
            "(status = 'failed', see the error column)",
            f"wall time: {self.wall_s:.2f} s on {self.cores} core(s) ({where}); kernels ready in "
            f"{self.warm_up_s:.2f} s; simulation CPU {self.cpu_s:.2f} s",
            f"throughput: {self.traces_per_core_s:.3f} traces per core-second "
            f"({60 * self.traces_per_core_s:.2f} per core-minute)",
            f"wrote {self.out} (regime=*/trace-*.parquet, {MANIFEST_FILE})",
        ]
        return "\n".join(lines)


def generate(
    spec: Spec,
    out: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    on_trace: Callable[[dict], None] | None = None,
) -> Summary:
    """Generate the spec's traces into ``out``, skipping those already there.

    ``workers``: local worker processes (default: all cores; 0 runs in this process);
    ``scheduler``: the address of a Dask scheduler to run on instead. Kernels are compiled in
    this process before the workers start; ``on_trace`` is called with the labels of each trace
    written. Returns a :class:`Summary`.
    """
    t_start = time.perf_counter()
    client = None
    if scheduler:  # before anything is written: a cluster that cannot be reached is an input
        from distributed import Client

        try:
            client = Client(scheduler, timeout="20s")
        except OSError as exc:
            raise DatasetDirError(f"--scheduler {scheduler!r}: cannot connect ({exc})") from None
    try:
        out = prepare_output(spec, out)
        with _locked(out):
            summary = _generate_into(spec, out, workers, client, progress, on_trace, t_start)
    finally:
        if client is not None:
            client.close()
    summary.scheduler = scheduler
    return summary


def _generate_into(spec, out, workers, client, progress, on_trace, t_start) -> Summary:
    ctx = spec.context
    metadata = part_metadata(spec)
    _remove_stale_temporaries(out)
    done = done_trace_ids(out)
    local = client is None
    if local and workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    # the forkserver's imports overlap the design and the parent's kernel compilation
    mp = _process_context() if local and workers and len(done) < spec.n_traces else None
    tasks = [t for t in design_traces(spec) if t.trace_id not in done]
    if local:
        workers = min(workers, len(tasks)) if workers else 0
    warm_s = warm_up(ctx, imports=local and not workers) if tasks else 0.0  # compile first
    if local:
        cores = max(workers, 1)
        results = _local_results(ctx, tasks, workers, out, metadata, mp)
    else:
        cores = sum(client.nthreads().values())
        results = _dask_results(ctx, tasks, client, out, metadata)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=spec.n_traces, initial=len(done), unit="trace", desc="generate")
    generated = failed = 0
    cpu = 0.0
    try:
        for rec in results:  # each one's part file is written
            generated += 1
            failed += rec["status"] != STATUS_OK
            cpu += rec["cpu_s"]
            if on_trace is not None:
                on_trace({k: v for k, v in rec.items() if k not in _SIGNALS})
            if bar is not None:
                bar.update(1)
                if failed:
                    bar.set_postfix(failed=failed)
    finally:
        if bar is not None:
            bar.close()
    manifest = write_manifest(spec, out)
    wall = time.perf_counter() - t_start
    return Summary(
        out=str(out),
        n_traces=spec.n_traces,
        already_done=len(done),
        generated=generated,
        failed_now=failed,
        failed_total=len(manifest["failed"]),
        wall_s=wall,
        warm_up_s=warm_s,
        cores=cores,
        cpu_s=cpu,
    )


def write_manifest(spec: Spec, out: Path) -> dict:
    """``_manifest.json`` from the part files present (written atomically, last)."""
    import pyarrow.dataset as pads

    done = done_trace_ids(out)
    failed: list[int] = []
    regimes: dict[str, int] = {}
    if done:
        table = pads.dataset(
            [str(p) for p in done.values()], format="parquet", partitioning=None
        ).to_table(columns=["trace_id", "status"])
        ids = table.column("trace_id").to_pylist()
        status = table.column("status").to_pylist()
        failed = sorted(i for i, s in zip(ids, status, strict=True) if s != STATUS_OK)
        for p in done.values():
            regime = p.parent.name.split("=", 1)[1]
            regimes[regime] = regimes.get(regime, 0) + 1
    expected = set(range(spec.n_traces))
    manifest = {
        "version": __version__,
        "name": spec.name,
        "n_traces": spec.n_traces,
        "complete": set(done) == expected,
        "done": len(done),
        "failed": failed,
        "regimes": dict(sorted(regimes.items())),
        "missing": sorted(expected - set(done)),
        "layout": "regime=<regime>/trace-<id>.parquet, one row per trace, signals as list columns",
    }
    _write_json(out / MANIFEST_FILE, manifest)
    return manifest


def read_dataset(out: str | Path, columns: list[str] | None = None, regimes=None):
    """The dataset as a pandas DataFrame sorted by trace_id (``regimes``: a subset)."""
    import pandas as pd

    filters = [("regime", "in", list(regimes))] if regimes else None
    df = pd.read_parquet(out, columns=columns, filters=filters)
    if "trace_id" in df:
        df = df.sort_values("trace_id", ignore_index=True)
    return df
