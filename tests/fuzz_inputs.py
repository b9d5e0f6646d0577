"""Inputs for the fuzz of the command line's input contract (tests/test_fuzz.py).

Structured inputs follow the layout the commands read: scene sections and keys from the
dataclasses of :mod:`signatelec.config.scene` and its ``OPTIONS``, spec tables from the rows of
:mod:`signatelec.config.constraints`, traces as a clean ball-pass ripple; each value is mostly
one the rules allow (so that the rules of the whole input and the runs are reached) and now and
then a wild one: huge, tiny, negative, NaN and infinite numbers, 400-digit integers, strings,
booleans, arrays, nested tables, unknown keys and sections. Raw inputs are arbitrary bytes and
text.
"""

from __future__ import annotations

import contextlib
import json
import math
from dataclasses import MISSING, fields
from pathlib import Path

import numpy as np
from hypothesis import strategies as st

from signatelec.config.bearing import MATERIALS, Bearing, Material
from signatelec.config.constraints import DATASET, DESIGN_KINDS, FACTORS, MEASUREMENT
from signatelec.config.options import OPTION_TABLE
from signatelec.config.scene import SECTIONS, Procedure
from signatelec.engines.fidelity import FIDELITY_NAMES
from signatelec.physics.stability import SPIN_UP_MIN_S


def write_input(path: Path, text: str | bytes) -> Path:
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


# --- TOML text --------------------------------------------------------------------------------


def toml_string(text: str) -> str:
    """A TOML basic string: JSON's escapes, and DEL (which JSON leaves as it is)."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def toml_key(key: str) -> str:
    if key and all(c.isalnum() and c.isascii() or c in "_-" for c in key):
        return key
    return toml_string(key)


def toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)  # nan, inf, -inf and 1e+300 are TOML as Python writes them
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def toml_text(data: dict) -> str:
    """TOML of ``data``: top-level tables as ``[section]`` headers, an array of tables as
    ``[[name]]`` blocks, deeper tables inline."""

    def blocks(value) -> bool:
        return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)

    lines = [
        f"{toml_key(k)} = {toml_value(v)}"
        for k, v in data.items()
        if not isinstance(v, dict) and not blocks(v)
    ]
    for key, value in data.items():
        tables = [value] if isinstance(value, dict) else value if blocks(value) else []
        for table in tables:
            lines.append(
                f"[{toml_key(key)}]" if isinstance(value, dict) else f"[[{toml_key(key)}]]"
            )
            lines.extend(f"{toml_key(k)} = {toml_value(v)}" for k, v in table.items())
    return "\n".join(lines) + "\n"


# --- values -----------------------------------------------------------------------------------

HUGE = int("1" + "0" * 399)
names = st.text(
    alphabet=st.characters(exclude_categories=["Cs"], max_codepoint=0x2FFF), max_size=12
)
wild_numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 5e-324, 1e-300, 1e300, -1e300, HUGE, -HUGE, 2**63, 2**64, -1]),
    st.integers(min_value=-(2**70), max_value=2**70),
)
wild_scalars = st.one_of(wild_numbers, names, st.booleans())
wild_values = st.recursive(
    wild_scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(names, inner, max_size=3)),
    max_leaves=6,
)


def near(default: float) -> st.SearchStrategy:
    """A number around a default (scaled, signed, zero)."""
    base = default if default else 1e-6
    return st.one_of(
        st.sampled_from([0.25, 0.5, 0.9, 1.1, 2.0, 10.0, 0.0, -1.0]).map(lambda f: base * f),
        st.floats(-1.0, 4.0).map(lambda f: base * f),
        wild_numbers,
    )


def rarely(n: int) -> st.SearchStrategy:
    """True once in ``n`` draws (hypothesis favours the ends of an integer range)."""
    return st.sampled_from([False] * (n - 1) + [True])  # the first is the simplest


def weighted(*choices: tuple[int, st.SearchStrategy]) -> st.SearchStrategy:
    """One of the strategies, each as often as its weight (``st.one_of`` merges equal
    branches, so repeating one there does not weight it)."""
    table = [strategy for weight, strategy in choices for _ in range(weight)]
    return st.sampled_from(range(len(table))).flatmap(lambda i: table[i])


def mostly(valid: st.SearchStrategy, other: st.SearchStrategy) -> st.SearchStrategy:
    """``valid`` six times in eight, ``other`` or a wild value otherwise: most inputs then get
    past most keys, so that the rules of the whole input and the runs are reached too."""
    return weighted((6, valid), (1, other), (1, wild_values))


def field_value(owner, f, section: str | None = None) -> st.SearchStrategy:
    """A value for field ``f`` of dataclass ``owner``: its default or a close one mostly."""
    default = f.default if f.default is not MISSING else f.default_factory()
    option = OPTION_TABLE.get((section, f.name)) if section else None
    if option is not None:
        return mostly(st.sampled_from([*option.values, True, False]), names)
    if isinstance(default, bool):
        return mostly(st.booleans(), st.integers(0, 1))
    if isinstance(default, int):
        return mostly(st.just(default), st.one_of(st.integers(-2, 40), st.just(10_001)))
    if isinstance(default, float):
        close = st.sampled_from([1.0, 1.0, 0.95, 1.05]).map(lambda x: default * x)
        return mostly(close, near(default))
    if isinstance(default, str):
        return mostly(names, st.integers())
    if isinstance(default, Material):
        return mostly(
            st.sampled_from(list(MATERIALS)),
            st.one_of(
                st.just("unobtainium"),
                st.fixed_dictionaries(
                    {k.name: near(getattr(default, k.name)) for k in fields(Material)[1:]}
                    | {"name": names}
                ),
                st.dictionaries(st.sampled_from(["name", "poisson", "colour"]), wild_scalars),
            ),
        )
    return wild_values


def section_table(owner, section: str | None, max_keys: int = 4) -> st.SearchStrategy:
    """A table of some of ``owner``'s fields, now and then with an unknown key."""
    keys = list(fields(owner))
    known = st.lists(st.sampled_from(keys), max_size=max_keys, unique_by=lambda f: f.name).flatmap(
        lambda fs: st.fixed_dictionaries({f.name: field_value(owner, f, section) for f in fs})
    )
    unknown = st.dictionaries(
        st.one_of(names, st.sampled_from(["electrical", "spin_up", "radial_load", "dt"])),
        wild_values,
        max_size=1,
    )
    return weighted((9, known), (1, st.tuples(known, unknown).map(lambda t: t[0] | t[1])))


def setup_time_s(procedure: dict) -> float:
    """The set-up time the procedure table asks for (defaults where a value is not a number)."""
    total = 0.0
    for key in ("clearance_time_s", "load_time_s", "spin_up_time_s"):
        default = getattr(Procedure(), key)
        if not isinstance(default, int | float):  # "auto": at least the shortest automatic one
            default = SPIN_UP_MIN_S
        value = procedure.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int | float):
            value = default
        with contextlib.suppress(OverflowError):
            total += float(value)
    return total


@st.composite
def scene_tables(draw, reserved: tuple[str, ...] = ()) -> dict:
    """A scene as a dict of sections; its duration mostly a little past its set-up."""
    owners = {"bearing": Bearing, **SECTIONS}
    chosen = draw(st.lists(st.sampled_from(list(owners)), max_size=3, unique=True))
    scene = {name: draw(section_table(owners[name], name, 3)) for name in chosen}
    if draw(rarely(20)):
        scene[draw(st.sampled_from(["operation", "effect", "extra"]))] = draw(wild_values)
    if draw(rarely(20)) and scene:
        scene[draw(st.sampled_from(sorted(scene)))] = draw(wild_scalars)
    numerics = scene.get("numerics")
    if "duration_s" not in reserved and (numerics is None or isinstance(numerics, dict)):
        procedure = scene.get("procedure")
        setup = setup_time_s(procedure if isinstance(procedure, dict) else {})
        if not draw(rarely(5)):
            delta = draw(st.sampled_from([1e-4, 5e-4, 2e-3, 0.0, -1e-4]))
            scene["numerics"] = (numerics or {}) | {"duration_s": setup + delta}
    for section, key in (s.split(".") for s in reserved):
        if isinstance(scene.get(section), dict):
            scene[section].pop(key, None)
    return scene


raw_text = st.one_of(
    st.binary(max_size=200),
    st.text(max_size=200),
    st.sampled_from(["", "[", "[operating\n", "a = ", "x = 1\nx = 2\n", "\x00", "[[numerics]]\n"]),
)


fidelities = st.sampled_from(
    ["quasistatic"] * 6 + [f for f in FIDELITY_NAMES if f != "quasistatic"]
)


sample = st.sampled_from
_DATASET_KEYS = {
    "name": mostly(names, st.integers()),
    "description": mostly(names, st.booleans()),
    "seed": mostly(st.integers(0, 2**63 - 1), sample([-1, 2**63, HUGE])),
    "fidelity": mostly(st.just("quasistatic"), sample([*FIDELITY_NAMES, "exact"])),
    "duration_s": mostly(sample([1e-3, 2e-3, 4e-3]), sample([0.0, -1e-3, 11.0, 1e-9])),
    "settle_s": mostly(sample([0.0, 1e-3, 2e-3]), sample([-1e-3, 20.0])),
}
_MEASUREMENT_KEYS = {
    "sample_rate_hz": mostly(sample([5e3, 1e4, 2e4]), sample([0.0, 1e7, 10.0, 1e-300])),
    "oversample": mostly(sample([1, 2, 4]), sample([0, 65, 2.0])),
    "anti_alias": mostly(st.booleans(), st.just(1)),
    "anti_alias_order": mostly(sample([1, 8, 16]), sample([0, 17])),
    "anti_alias_cutoff": mostly(sample([0.5, 0.8]), sample([0.0, 1.0])),
    "noise_fraction": mostly(
        sample([0.0, 0.01, [0.001, 0.01]]), sample([[0.01, 0.001], [0.1], [], 2.0])
    ),
    "drift_fraction": mostly(sample([0.0, [0.0, 0.002]]), sample([-0.1, [0, 1, 2]])),
    "offset_ohm": mostly(sample([0.0, [-2e-4, 2e-4]]), sample([2.0, [-2.0, 0.0]])),
    "quantisation_ohm": mostly(sample([0.0, 1e-7]), sample([0.1, -1e-7])),
}
# keys the tables gain later are fuzzed with wild values until they get values of their own
for _rows, _keys in ((DATASET, _DATASET_KEYS), (MEASUREMENT, _MEASUREMENT_KEYS)):
    for _row in _rows:
        _keys.setdefault(_row.key, wild_values)

#: Per factor: allowed values, then values the scene's rules refuse.
_FACTOR_NUMBERS = {
    "radial_load_n": ([1000.0, 5820.0, 0.0], [-1.0, 1e9]),
    "radial_load_fraction": ([0.05, 0.2, 0.4], [-0.1, 100.0]),
    "clearance_m": ([-15e-6, 0.0, 10e-6], [1.0, -1e-3]),
    "epsilon": ([0.3, 0.5, 0.6], [0.0, 25.0]),
    "omega_rad_s": ([250.0, 500.0, 0.0], [-5.0, 1e9]),
    "initial_ball_angle_rad": ([0.0, 0.4, -3.0], [1e6]),
    "condition": (["healthy", "outer", "ball", "unbalance"], ["rusty", 2.0]),
    "spall_length_m": ([0.5e-3, 1.5e-3], [-1e-3, 1.0]),
    "spall_depth_m": ([20e-6, 50e-6], [0.0, 1.0]),
    "spall_angle_rad": ([0.0, 0.5], [1e6]),
    "unbalance_force_n": ([0.0, 500.0], [-1.0, 1e9]),
    "unbalance_phase_rad": ([0.0, 1.0], [1e6]),
}


def chosen_table(values: dict, max_keys: int) -> st.SearchStrategy:
    keys = st.lists(st.sampled_from(sorted(values)), max_size=max_keys, unique=True)
    return keys.flatmap(lambda ks: st.fixed_dictionaries({k: values[k] for k in ks}))


@st.composite
def factor_tables(draw, name: str) -> dict:
    valid, refused = _FACTOR_NUMBERS[name]
    number = mostly(sample(valid), sample(refused))
    form = draw(sample(["value", "values", "range", "range", "value", "mixed", "wild"]))
    if form == "value":
        return {"value": draw(number)}
    if form == "values":
        return {"values": draw(st.lists(number, min_size=draw(sample([1, 1, 0])), max_size=2))}
    if form == "range":
        ends = draw(st.lists(sample(valid + refused * draw(rarely(4))), min_size=2))
        # a refused end may be a word where the valid ones are numbers: order by type first
        lo, hi = sorted(ends[:2], key=lambda v: (type(v).__name__, v))[
            :: -1 if draw(rarely(10)) else 1
        ]
        table = {"min": lo, "max": hi}
        if draw(st.booleans()):
            table["levels"] = draw(mostly(sample([1, 2]), sample([0, 10_001])))
        if draw(rarely(4)):
            table["scale"] = draw(sample(["log", "linear", "cubic"]))
        return table
    if form == "mixed":
        keys = ["value", "values", "min", "max", "levels", "scale", "step"]
        return draw(st.dictionaries(st.sampled_from(keys), number, max_size=3))
    return draw(wild_values)


@st.composite
def design_blocks(draw) -> dict:
    kind = draw(st.sampled_from([*DESIGN_KINDS, "random", "random", "sobol"]))
    block: dict = {"kind": kind}
    if kind != "grid" or draw(st.booleans()):
        block["n_traces"] = draw(mostly(sample([1, 2]), sample([0, -1, 10**7])))
    chosen = draw(st.lists(st.sampled_from([*FACTORS, "speed"]), max_size=3, unique=True))
    factors = {}
    for name in chosen:
        factors[name] = draw(factor_tables(name)) if name in FACTORS else draw(wild_values)
    if factors or draw(st.booleans()):
        block["factors"] = factors
    if draw(rarely(20)):
        block[draw(names)] = draw(wild_values)
    return block


_RESERVED = ("numerics.duration_s", "numerics.sample_rate_hz", "numerics.fidelity")


@st.composite
def specs(draw) -> dict:
    spec = {}
    if not draw(rarely(10)):
        spec["dataset"] = draw(chosen_table(_DATASET_KEYS, 4))
        spec["dataset"].setdefault("fidelity", "quasistatic")
        spec["dataset"].setdefault("duration_s", 2e-3)
    if not draw(rarely(10)):
        spec["design"] = draw(st.lists(design_blocks(), min_size=1, max_size=2))
    elif draw(st.booleans()):
        spec["design"] = draw(st.one_of(design_blocks(), wild_values))
    if draw(st.booleans()):
        spec["measurement"] = draw(chosen_table(_MEASUREMENT_KEYS, 3))
    if draw(rarely(4)):
        scene = draw(scene_tables(reserved=_RESERVED))
        if draw(rarely(6)):  # keys the dataset sets itself
            scene.setdefault("numerics", {})
            if isinstance(scene["numerics"], dict):
                scene["numerics"]["sample_rate_hz"] = 1e4
        spec["scene"] = scene
    if draw(rarely(20)):
        spec[draw(st.sampled_from(["datasets", "designs", "meta"]))] = draw(wild_values)
    return spec


@st.composite
def trace_tables(draw) -> dict:
    """Columns of a trace: a clean 20 kHz ball-pass ripple, then mutations."""
    n = draw(sample([0, 1, 3, 5, 200, 400, 600, 1000, 600, 1000, 2000]))
    fs = draw(sample([20e3, 20e3, 20e3, 20e3, 50e3, 5e3, 1e9]))
    t = np.arange(n) / fs + draw(st.sampled_from([0.0, 0.0, 1e6, -5.0]))
    level = draw(weighted((8, st.just(1.5e-3)), (1, sample([1.5e-103, 1.5e-12, 1.5e5, 1.5e8]))))
    r = level * (1 + 0.01 * np.sin(2 * np.pi * 400 * t))
    t, r = t.astype(object), r.astype(object)
    for _ in range(draw(sample([0, 0, 0, 0, 1, 1, 2, 3]))):
        if n == 0:
            break
        which = draw(st.sampled_from(["t", "r", "r", "r"]))
        column = t if which == "t" else r
        i = draw(st.integers(0, n - 1))
        span = draw(st.sampled_from([1, 1, 2, 20, n]))
        value = draw(
            st.one_of(
                st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1e-3, 1e308, "", "x"]),
                wild_scalars,
            )
        )
        column[i : i + span] = value
    if n and draw(rarely(10)):
        t = t[::-1].copy() if draw(st.booleans()) else np.repeat(t[: n // 2 + 1], 2)[:n]
    table = {
        draw(weighted((8, st.just("time_s")), (1, st.just("t")), (1, names))): list(t),
        draw(
            weighted((8, st.just("resistance_ohm")), (1, sample(["R", "time_s"])), (1, names))
        ): list(r),
    }
    if draw(rarely(5)):
        table[draw(names)] = draw(st.lists(wild_scalars, min_size=n, max_size=n))
    return table


def write_trace(path: Path, table: dict) -> None:
    import pandas as pd

    df = pd.DataFrame(table)
    if path.suffix == ".parquet":
        for column in df.columns:  # one Parquet type per column: numbers, else text
            if not all(
                isinstance(v, float | int)
                and not isinstance(v, bool)
                and abs(v) < 1e308
                or isinstance(v, float)
                for v in df[column]
            ):
                df[column] = df[column].astype(str)
            else:
                df[column] = df[column].astype(float) if len(df) else df[column]
        df.to_parquet(path, index=False)
    else:
        df.to_csv(path, index=False, sep=path.suffix == ".tsv" and "\t" or ",")


omegas = weighted(
    (6, st.sampled_from(["500", "250", "750"])),
    (1, st.sampled_from(["0", "-500", "nan", "inf", "1e308", "x", "", "5\x1e0"])),
    (1, st.floats().map(repr)),
)
out_suffixes = st.sampled_from([None, None, ".json", ".parquet"])
