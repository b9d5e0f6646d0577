"""Are the monitor's regime errors separable from the trace? Twins of the design states.

Usage::

    python pipelines/monitor_twins.py [--bank DIR] [--out DIR] [--report FILE]

For each design state of the monitoring study that a load-state model of
``docs/monitor/model_error.md`` called in the wrong regime (:data:`TARGETS`: the states, with
the regime they were called), DEM runs at the paper's fidelity (velocity Verlet, dt = 1e-7 s;
the dataset machinery, :func:`signatelec.data.generate`, batched in the ensemble kernel) of

- the state itself at three initial ball angles (the run-to-run spread of one state: the DEM's
  own slow dynamics differ with the start), and
- a grid of states of the competing regime at the same speed: F_r over a band around the
  state's and epsilon over the regime's range (or, for the zero regime, clearance over
  -1..+1 um),

their clean 0.25 s steady traces measured as the monitor measures a stretch: the mean of the
features of 0.2 s windows tiled over the whole-pass trace. Along each epsilon (clearance) line
of the grid, the features are interpolated in log F_r to the state's mean level (the level
fixes F_r to ~1e-5 at a stretch, so a twin must match it), then between the lines in epsilon.
The difference from the state is measured in the noise of a stretch: the covariance of the
features of 0.2 s windows with 0.2 % white noise (Ledoit-Wolf), over n windows (2 s: n = 10,
10 s: n = 50); ``D`` is the Mahalanobis distance of the nearest twin (a Bayes decision between
two such means errs with probability Phi(-D/2)); ``D_replicate`` that of the state's own runs
from other ball angles (the spread no model can remove).

The states and their grids are cached in ``--out`` (default ``/tmp/monitor-twins``; 754 runs,
~7 min of CPU); the report goes to ``--report`` (default ``docs/monitor/twins.md``).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import pandas as pd
from monitor_bias import markdown

WINDOW_S = 0.2
NOISE = 0.002
NOISY_WINDOWS = 48
#: Design states a model of docs/monitor/model_error.md called wrong, with the regime it
#: called them (state index of the design bank: the fold of R(epsilon) near 0.345, the
#: vanishing first harmonic near 0.53-0.56, the +-1 um boundary).
TARGETS = {
    20: "zero",
    50: "zero",
    21: "clearance",
    33: "clearance",
    36: "clearance",
    12: "clearance",
    0: "zero",
    54: "zero",
    44: "zero",
    57: "clearance",
    68: "preload",
}
ANGLES_RAD = (0.0, 0.16, 0.32)
STRETCH_WINDOWS = {"2 s": 10, "10 s": 50}
#: Features compared: the model's (training.MODEL_FEATURES) but the speed, the level (matched)
#: and those that grow with the window's length.
SKIP = ("omega_rad_s", "level_mean_ohm", "harmonic_snr", "duration_ball_passes", "h1_amp_ohm")


def spec_of(states: pd.DataFrame) -> dict:
    """The dataset spec: per target the state at three ball angles, and its competing grid."""
    from signatelec.studies.monitor_records import OMEGA_RAD_S, SAMPLE_RATE_HZ

    designs = []
    for s, called in TARGETS.items():
        row = states.loc[s]
        f = float(row.radial_load_n)
        designs.append(
            {
                "kind": "grid",
                "factors": {
                    "radial_load_n": {"value": f},
                    "clearance_m": {"value": float(row.clearance_m)},
                    "omega_rad_s": {"value": OMEGA_RAD_S},
                    "initial_ball_angle_rad": {"values": list(ANGLES_RAD)},
                },
            }
        )
        grid = {"radial_load_n": {"min": 0.7 * f, "max": 1.4 * f, "levels": 7, "scale": "log"}}
        if called == "zero":
            grid["clearance_m"] = {"min": -1e-6, "max": 1e-6, "levels": 5}
        elif called == "clearance":
            grid["epsilon"] = {"min": 0.30, "max": 0.495, "levels": 14}
        else:
            grid["epsilon"] = {"min": 0.505, "max": 0.60, "levels": 8}
        grid["omega_rad_s"] = {"value": OMEGA_RAD_S}
        designs.append({"kind": "grid", "factors": grid})
    return {
        "dataset": {
            "name": "monitor_twins",
            "description": "Twins of the monitor's misread design states",
            "seed": 20261123,
            "fidelity": "dem",
            "duration_s": 0.25,
            "settle_s": 0.03,
        },
        "design": designs,
        "measurement": {"sample_rate_hz": SAMPLE_RATE_HZ},
        "scene": {"procedure": {"spin_up_time_s": 0.01}},
    }


def stretch_features(clean: np.ndarray, draws: int = NOISY_WINDOWS) -> tuple[dict, pd.DataFrame]:
    """The features of ``draws`` 0.2 s windows of the whole-pass tiled trace with 0.2 % white
    noise, and their mean (a stretch's mean features). Every run gets the same offsets (as
    fractions of its tile) and the same noise draws (common random numbers: the difference of
    two runs' means then carries little of the noise)."""
    from signatelec.estimation.features import trace_features
    from signatelec.studies.monitor_records import OMEGA_RAD_S, SAMPLE_RATE_HZ, whole_passes

    fs, n = SAMPLE_RATE_HZ, int(round(WINDOW_S * SAMPLE_RATE_HZ))
    rng = np.random.default_rng(20261123)
    tile = whole_passes(clean, fs, OMEGA_RAD_S)
    reps = np.tile(tile, n // tile.size + 2)
    level = float(np.median(tile))
    rows = []
    for _ in range(draws):
        o = int(rng.random() * tile.size)
        seg = reps[o : o + n] + NOISE * level * rng.standard_normal(n)
        rows.append(trace_features(seg, fs, OMEGA_RAD_S))
    frame = pd.DataFrame(rows)
    return frame.mean().to_dict(), frame


def runs_table(out: Path, states: pd.DataFrame, log) -> pd.DataFrame:
    """The generated runs' stretch features (cached as ``twins.parquet``)."""
    from signatelec.data import generate, read_dataset, spec_from_dict

    cache = out / f"twins-{NOISY_WINDOWS}.parquet"
    if cache.is_file():
        return pd.read_parquet(cache)
    spec = spec_from_dict(spec_of(states), "monitor_twins")
    generate(spec, out / "runs", workers=0, progress=True)
    runs = read_dataset(out / "runs")
    runs = runs[runs.status == "ok"].reset_index(drop=True)
    log(f"{len(runs)} runs")
    rows = []
    for run in runs.itertuples(index=False):
        f, _ = stretch_features(np.asarray(run.resistance_clean_ohm, float))
        rows.append(
            {
                "trace_id": int(run.trace_id),
                "design": int(run.design),
                "epsilon_target": float(run.epsilon_target),
                "radial_load_n": float(run.radial_load_n),
                "clearance_m": float(run.clearance_m),
                "epsilon": float(run.epsilon),
                "initial_ball_angle_rad": float(run.initial_ball_angle_rad),
                **f,
            }
        )
    table = pd.DataFrame(rows)
    table.to_parquet(cache)
    return table


def match_level(grid: pd.DataFrame, level: float, features: list[str], key: str) -> pd.DataFrame:
    """Per line of ``key`` (epsilon or clearance) the features interpolated in log F_r to
    ``level`` (lines whose level range misses it are dropped)."""
    out = []
    for k, line in grid.groupby(key):
        line = line.sort_values("level_mean_ohm")
        lv = line.level_mean_ohm.to_numpy()
        if not lv[0] <= level <= lv[-1]:
            continue
        row = {key: float(k)}
        for c in ["radial_load_n_log", "epsilon", *features]:
            row[c] = float(np.interp(level, lv, line[c].to_numpy()))
        out.append(row)
    return pd.DataFrame(out).sort_values(key).reset_index(drop=True)


def refine(lines: pd.DataFrame, key: str, cols: list[str], steps: int = 8) -> pd.DataFrame:
    """Linear interpolation between adjacent lines (``steps`` per gap)."""
    if len(lines) < 2:
        return lines
    parts = []
    for i in range(len(lines) - 1):
        a, b = lines.iloc[i], lines.iloc[i + 1]
        for t in np.linspace(0, 1, steps, endpoint=False):
            parts.append({c: (1 - t) * a[c] + t * b[c] for c in cols})
    parts.append(lines.iloc[-1][cols].to_dict())
    return pd.DataFrame(parts)


def distance(f, ref: pd.Series, scale: pd.Series, prec: np.ndarray, n: int):
    """Mahalanobis distance of features ``f`` from ``ref`` in the noise of the mean of ``n``
    windows (``scale`` and ``prec``: one window's per-feature sd and standardised precision),
    and the standardised differences."""
    z = ((f[ref.index].astype(float) - ref) / scale).to_numpy(float)
    return math.sqrt(float(z @ prec @ z) * n), z


def analyse(states, bank_traces, table, features, log) -> pd.DataFrame:
    """Per target: the nearest twin of the competing regime (level matched, then the least
    Mahalanobis distance at 2 and 10 s), the state's own runs from other ball angles and the
    bank's run, all against the state's own run at ball angle 0."""
    from sklearn.covariance import LedoitWolf

    table = table.assign(radial_load_n_log=np.log(table.radial_load_n))
    rows = []
    for i, (s, called) in enumerate(TARGETS.items()):
        st = states.loc[s]
        mean, noisy = stretch_features(bank_traces[s])
        # the noise of one 0.2 s window, standardised per feature (Ledoit-Wolf covariance)
        scale = noisy[features].std().replace(0.0, 1.0)
        prec = np.linalg.inv(LedoitWolf().fit((noisy[features] / scale).to_numpy()).covariance_)
        # the designs of spec_of: per target its own runs, then its competing grid; the
        # reference is its own run at ball angle 0, through the same machinery as its twins
        # (the bank's run, read by the study, differs by its start and its filter)
        own = table[table.design == 2 * i]
        grid = table[table.design == 2 * i + 1]
        ref = own[own.initial_ball_angle_rad == 0].iloc[0]
        f_state = ref[features].astype(float)
        key = "clearance_m" if called == "zero" else "epsilon_target"
        lines = match_level(grid, float(ref["level_mean_ohm"]), features, key)
        if lines.empty:
            log(f"state {s}: no twin line reaches its level")
            continue
        fine = refine(lines, key, ["radial_load_n_log", "epsilon", *features])
        reps = own[own.initial_ball_angle_rad > 0]
        row = {
            "state": s,
            "regime": st.regime,
            "called": called,
            "radial_load_n": float(st.radial_load_n),
            "clearance_um": 1e6 * float(st.clearance_m),
            "epsilon": float(st.epsilon),
        }
        for label, n in STRETCH_WINDOWS.items():
            d = [distance(fine.iloc[j], f_state, scale, prec, n)[0] for j in range(len(fine))]
            best = int(np.argmin(d))
            row[f"D_{label}"] = d[best]
            row[f"D_replicate_{label}"] = float(
                np.median([distance(r, f_state, scale, prec, n)[0] for _, r in reps.iterrows()])
            )
            if label == "2 s":
                z = distance(fine.iloc[best], f_state, scale, prec, n)[1]
                top = np.argsort(-np.abs(z))[:3]
                row["twin_Fr_n"] = float(np.exp(fine.iloc[best].radial_load_n_log))
                row["twin_epsilon"] = float(fine.iloc[best].epsilon)
                # the load zone's half-angle (Harris 2006, ch. 7), state and twin
                psi = [
                    math.degrees(math.acos(1.0 - 2.0 * e))
                    for e in (st.epsilon, row["twin_epsilon"])
                ]
                row["psi_l_deg"] = f"{psi[0]:.0f} / {psi[1]:.0f}"
                row["twin_features"] = ", ".join(f"{features[j]} {z[j]:+.1f}" for j in top)
                row["D_bank_2 s"] = distance(pd.Series(mean), f_state, scale, prec, n)[0]
        rows.append(row)
        log(
            f"state {s} ({st.regime}, eps {st.epsilon:.3f}) vs {called}: "
            + ", ".join(f"{k} {v:.3g}" for k, v in row.items() if k.startswith("D_"))
        )
    return pd.DataFrame(rows)


def report_lines(result: pd.DataFrame) -> list[str]:
    """The findings, read off the table."""
    d2, r2 = result["D_2 s"], result["D_replicate_2 s"]
    return [
        "# Are the monitor's regime errors separable? Twins of the misread design states",
        "",
        f"Written by `python pipelines/monitor_twins.py` (its docstring says how). The "
        f"{len(result)} design states of `signatelec study monitor` that a load-state "
        "model of [model_error.md](model_error.md) called in the wrong regime, each against "
        "DEM runs at the paper's fidelity of the competing regime at the same speed (F_r "
        "0.7-1.4x the state's, epsilon over the regime's range or clearance over -1..+1 um), "
        "the nearest of them matched in level and interpolated in epsilon. Distances are "
        "Mahalanobis distances of a stretch's mean features (the model's features but the "
        "speed, the level and the length-dependent ones) in the noise of a stretch of 2 s "
        "(10 windows of 0.2 s at 0.2 % white noise) or 10 s; `twin_features` the largest "
        "differences in units of one window's noise sd; `psi_l_deg` the load zone's "
        "half-angle psi_l = arccos(1 - 2 epsilon) (Harris 2006, ch. 7) of the state and of "
        "its twin (the seed's 13 balls 27.7 deg apart: about 2 psi_l / 27.7 deg of them are loaded "
        "and conduct at a time).",
        "",
        f"**They are separable.** The nearest twin of the competing regime lies "
        f"{d2.min():.1f}-{d2.max():.1f} noise standard deviations away at 2 s (median "
        f"{d2.median():.1f}); the state's own runs from other initial ball angles lie "
        f"{r2.min():.1f}-{r2.max():.1f} away (median {r2.median():.1f}: the residual of the "
        "48-window means and the DEM's start, the floor any comparison has). A Bayes decision "
        "between two such means errs with probability Phi(-D/2): below 1 % from D = 4.7. The "
        "fold of R(epsilon) (epsilon ~0.345 against zero) is told apart by the cage slip and "
        "the ripple's shape (crest, skew, asymmetry), the first-harmonic null (0.53-0.56 "
        "against clearance) by the second harmonic and the ripple's shape, the states 0.2-0.5 "
        "um beyond the +-1 um boundary by the first harmonic, the slip and the ripple's MAD "
        "and skew. The information is in the trace at this noise; the model did not read it "
        "there: its training runs were too thin near these states.",
        "",
    ]


def main(argv=None):
    from signatelec.estimation.training import MODEL_FEATURES
    from signatelec.studies.monitor_records import CALIBRATION_STATES, DESIGN_SEED, dem_bank

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bank", default="/tmp/monitor-bank/design")
    p.add_argument("--out", default="/tmp/monitor-twins")
    p.add_argument("--report", default="docs/monitor/twins.md")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    bank = dem_bank(args.bank, print, CALIBRATION_STATES, DESIGN_SEED)
    states = bank.set_index("state")
    features = [c for c in MODEL_FEATURES if c not in SKIP]
    table = runs_table(out, states, print)
    traces = dict(zip(bank.state, bank.resistance, strict=True))
    result = analyse(states, traces, table, features, print)
    result.to_parquet(out / "twins_distance.parquet")
    text = "\n".join([*report_lines(result), *markdown(result.round(3)), ""])
    print(text)
    if args.report:
        Path(args.report).write_text(text)
    return result


if __name__ == "__main__":
    main()
