"""The records of the monitoring study: a bank of paper-fidelity DEM runs, and long records
assembled from them (:mod:`signatelec.studies.monitor` describes the study).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.config.bearing import Bearing
from signatelec.config.scene import Scene
from signatelec.engines.fidelity import apply_fidelity
from signatelec.engines.simulate import simulate
from signatelec.physics.quasistatic import clearance_for_epsilon
from signatelec.physics.regimes import regime_of

#: Held-out states in the bank (a third per regime) and the speed of every run: as many as
#: the calibration bank's, so that a 90 % coverage over the records' states (the stretches of
#: one state share its model error) has a binomial standard error of ~4 points, not the 6.5 of
#: 21 states, against the 5-point tolerance of the acceptance condition.
BANK_STATES = 72
OMEGA_RAD_S = 500.0
#: Steady trace kept per run, and the settling after the spin-up that is skipped (the ring and
#: cage settle for ~25 ms: ``datasets/load_state.toml``).
STEADY_S = 0.25
SETTLE_S = 0.03
SAMPLE_RATE_HZ = 20000.0
#: White noise per sample, relative to the level (the acceptance condition's).
NOISE = 0.002
BANK_SEED = 20261122
#: The calibration bank (the stretch intervals' model-error term, not the acceptance records):
#: states drawn alike from another seed, which informed nothing else. A conformal quantile
#: covers new states only if its calibration states are exchangeable with them (Vovk et al.
#: 2005, ch. 2), so they must not have chosen the model's training runs. 288 states (the first
#: 72 of this seed were the whole bank once): with 72 the quantile per estimated regime rested
#: on ~24 states, and the ratios fitted on two thirds of them covered 87.5-89.4 % of the
#: others' stretches, short of the nominal 90 %.
CALIBRATION_STATES = 288
CALIBRATION_SEED = 20263777
#: The design bank: states drawn alike from a third seed, on which the model's training runs
#: near the regime boundaries were placed (where the model misread them) and the change
#: detector was chosen (``pipelines/monitor_twins.py``, ``monitor_bias.py``,
#: ``monitor_change_detection.py``); neither the acceptance nor the calibration records.
DESIGN_SEED = 20261999


def bank_states(n: int = BANK_STATES, seed: int = BANK_SEED) -> pd.DataFrame:
    """The held-out states: F_r, target epsilon, clearance (quasi-static theory), regime."""
    rng = np.random.default_rng(seed)
    bearing = Bearing()
    rows = []
    for i in range(n):
        kind = ("preload", "zero", "clearance")[i % 3]
        load = float(np.exp(rng.uniform(math.log(2500.0), math.log(12500.0))))
        if kind == "zero":
            clearance = 0.0
        else:
            eps = rng.uniform(0.505, 0.6) if kind == "preload" else rng.uniform(0.3, 0.495)
            clearance = clearance_for_epsilon(bearing, load, OMEGA_RAD_S, float(eps))
        rows.append(
            {
                "state": i,
                "radial_load_n": load,
                "clearance_m": float(clearance),
                "regime": regime_of(float(clearance)),
            }
        )
    return pd.DataFrame(rows)


def run_state(row: dict, fidelity: str | None = None) -> pd.DataFrame:
    """The steady trace of one bank state (``time_s``, ``resistance_ohm``, ``epsilon``): the
    paper's numerics, or a preset of :mod:`signatelec.engines.fidelity` (``fidelity``)."""
    scene = Scene().with_overrides(
        radial_load_n=row["radial_load_n"],
        clearance_m=row["clearance_m"],
        omega_rad_s=OMEGA_RAD_S,
        sample_rate_hz=SAMPLE_RATE_HZ,
    )
    setup = scene.procedure.clearance_time_s + scene.procedure.load_time_s
    setup += scene.procedure.spin_up_time_s
    scene = scene.with_overrides(duration_s=setup + SETTLE_S + STEADY_S)
    if fidelity is not None:
        scene = apply_fidelity(scene, fidelity)
    result = simulate(scene)
    sig = result.signals
    steady = sig[(sig["phase"] == "steady") & (sig["time_s"] >= setup + SETTLE_S)]
    return steady[["time_s", "resistance_ohm", "epsilon"]].reset_index(drop=True)


def dem_bank(
    directory: str | Path,
    log: Callable[[str], None] | None = None,
    n: int = BANK_STATES,
    seed: int = BANK_SEED,
) -> pd.DataFrame:
    """The bank's states (:func:`bank_states` of ``n`` and ``seed``) with their steady traces
    (``resistance`` as a list column), each run cached in ``directory`` as
    ``state-<i>.parquet``."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    states = bank_states(n, seed)
    traces, eps = [], []
    for row in states.to_dict("records"):
        path = directory / f"state-{row['state']:03d}.parquet"
        if path.is_file():
            steady = pd.read_parquet(path)
        else:
            start = time.process_time()
            steady = run_state(row)
            steady.to_parquet(path.with_suffix(".part"))
            path.with_suffix(".part").rename(path)
            if log:
                log(
                    f"bank state {row['state']}: F_r {row['radial_load_n']:.0f} N, clearance "
                    f"{row['clearance_m'] * 1e6:+.1f} um, {time.process_time() - start:.1f} s CPU"
                )
        traces.append(steady["resistance_ohm"].to_numpy())
        eps.append(float(steady["epsilon"].mean()))
    states["epsilon"] = eps
    states["resistance"] = traces
    return states


def whole_passes(
    resistance_ohm: np.ndarray, fs: float, omega_rad_s: float, bearing=None
) -> np.ndarray:
    """The trace cut to the whole number of ball passes nearest its length (f_bp of
    ``bearing``, default the seed's, found by the analysis), so that a tiling continues the
    ripple across the seam to within half a sample."""
    from signatelec.estimation.analysis import analyse_trace

    f_bp = analyse_trace(resistance_ohm, fs, omega_rad_s, bearing=bearing).ball_pass_hz
    passes = math.floor(resistance_ohm.size / fs * f_bp)
    return resistance_ohm[: int(round(passes * fs / f_bp))]


def assemble_record(
    bank: pd.DataFrame,
    rng: np.random.Generator,
    n_stretches: int,
    final_constant_s: float | None = None,
    fs: float = SAMPLE_RATE_HZ,
) -> tuple[np.ndarray, pd.DataFrame]:
    """A noisy record and its truth (one row per stretch: start_s, end_s and the state).

    Each next state is drawn among the bank's states that differ from the current one by a
    load step of 10-50 % at the same regime, or by the regime."""
    tiles = {
        int(s): whole_passes(r, fs, OMEGA_RAD_S)
        for s, r in zip(bank.state, bank.resistance, strict=True)
    }
    by_state = bank.set_index("state")
    state = int(rng.choice(bank.state.to_numpy()))
    pieces, truth, t0 = [], [], 0.0
    for i in range(n_stretches + (final_constant_s is not None)):
        if i == n_stretches:
            length = final_constant_s
        else:
            length = float(rng.uniform(2.0, 10.0))
        n = int(round(length * fs))
        tile = tiles[state]
        reps = np.tile(tile, n // tile.size + 2)
        offset = int(rng.integers(tile.size))
        pieces.append(reps[offset : offset + n])
        row = by_state.loc[state]
        truth.append(
            {
                "start_s": t0,
                "end_s": t0 + n / fs,
                "state": state,
                "radial_load_n": float(row.radial_load_n),
                "epsilon": float(row.epsilon),
                "clearance_m": float(row.clearance_m),
                "regime": row.regime,
            }
        )
        t0 += n / fs
        if i < n_stretches - 1 + (final_constant_s is not None):
            load = by_state.radial_load_n
            step = (load / float(row.radial_load_n) - 1.0).abs()
            same = by_state.regime == row.regime
            ok = (same & (step >= 0.10) & (step <= 0.50)) | (~same & (step <= 0.50))
            ok &= by_state.index != state
            state = int(rng.choice(by_state.index[ok].to_numpy()))
    clean = np.concatenate(pieces)
    level = np.repeat([np.median(p) for p in pieces], [p.size for p in pieces])
    noisy = clean + NOISE * level * rng.standard_normal(clean.size)
    return noisy, pd.DataFrame(truth)


def write_record(path: Path, resistance_ohm: np.ndarray, fs: float) -> None:
    """A record as the Parquet trace ``signatelec monitor`` reads."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table(
        {"time_s": np.arange(resistance_ohm.size) / fs, "resistance_ohm": resistance_ohm}
    )
    # rows in time order, declared so (the reader then needs only the time column's ends)
    pq.write_table(table, path, row_group_size=1 << 20, sorting_columns=[pq.SortingColumn(0)])
