"""Where the monitor's per-state bias comes from, on the design bank of the monitoring study.

Usage::

    python pipelines/monitor_bias.py [--bank DIR] [--out DIR] [--draws N]

The design states of ``signatelec study monitor`` (paper fidelity: velocity Verlet,
dt = 1e-7 s; ``--bank``, default ``/tmp/monitor-bank/design``, read as cached or run) are
run again at the ``fast`` preset the default model trains on (cached in ``--out``). From each
state's steady trace, at each fidelity, ``--draws`` windows of the monitor's 0.2 s at random
offsets of the whole-pass tiling (as the study's records are assembled) with 0.2 % white noise,
and clean windows at the same offsets, are measured and estimated by the default model. Per
state it compares

1. *fidelity*: the estimates (and features) of the paper-fidelity and the fast-preset windows;
2. *noise*: the mean of the noisy windows' estimates (a stretch's estimate), the estimate of the
   clean windows and the estimate of the noisy windows' mean features;
3. *the regime near a boundary*: states within the model's clearance error of the +-1 um
   boundaries; the regime of the combined classifier against the regime of the combined
   clearance estimate;
4. *capacity*: the error on the fast-preset runs (held out, at the training fidelity).

Each comparison is made for four load-state models: trained on half and on all of the 1200
fast-preset runs of the shipped table (all: the default model before the paper-fidelity runs
joined it), on those and the 1200 paper-fidelity runs of the same design (the default model
before the runs placed near the regime boundaries joined it), and the default model (those and
the 600 placed runs): 10 to 15 min of CPU.
The report goes to ``--report`` (default ``docs/monitor/model_error.md``), the tables to
``--out`` (default ``out/monitor_bias``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

WINDOW_S = 0.2
NOISE = 0.002


def fast_bank(states: pd.DataFrame, directory: Path) -> list[np.ndarray]:
    """The states' steady traces at the ``fast`` preset, cached as ``fast-<i>.parquet``."""
    from signatelec.studies.monitor_records import run_state

    traces = []
    for row in states.to_dict("records"):
        path = directory / f"fast-{row['state']:03d}.parquet"
        if not path.is_file():
            run_state(row, "fast").to_parquet(path)
        traces.append(pd.read_parquet(path)["resistance_ohm"].to_numpy())
    return traces


def windows_of(states, traces, fidelity: str, draws: int, seed: int) -> pd.DataFrame:
    """Features of ``draws`` noisy and clean 0.2 s windows per state (same offsets)."""
    from signatelec.estimation.features import trace_features
    from signatelec.studies.monitor_records import OMEGA_RAD_S, SAMPLE_RATE_HZ, whole_passes

    rng = np.random.default_rng(seed)
    fs, n = SAMPLE_RATE_HZ, int(round(WINDOW_S * SAMPLE_RATE_HZ))
    rows = []
    for state, trace in zip(states.state, traces, strict=True):
        tile = whole_passes(trace, fs, OMEGA_RAD_S)
        reps = np.tile(tile, n // tile.size + 2)
        level = float(np.median(tile))
        for d in range(draws):
            off = int(rng.integers(tile.size))
            clean = reps[off : off + n]
            noisy = clean + NOISE * level * rng.standard_normal(n)
            for kind, seg in (("clean", clean), ("noisy", noisy)):
                f = trace_features(seg, fs, OMEGA_RAD_S)
                rows.append(
                    {"state": int(state), "fidelity": fidelity, "kind": kind, "draw": d, **f}
                )
    return pd.DataFrame(rows)


def estimates(model, frame: pd.DataFrame) -> pd.DataFrame:
    pred = model.predict_frame(frame)
    return pd.concat([frame[["state", "fidelity", "kind", "draw"]], pred], axis=1)


def combine(est: pd.DataFrame) -> pd.DataFrame:
    """Per state, fidelity and kind: the stretch-like combination (mean of log F_r, epsilon,
    clearance; the regime of the summed log-probabilities, :func:`combine_classes`)."""
    from signatelec.estimation.evidence import combine_classes

    out = []
    for (state, fid, kind), g in est.groupby(["state", "fidelity", "kind"]):
        probs = combine_classes(g, "regime")
        out.append(
            {
                "state": state,
                "fidelity": fid,
                "kind": kind,
                "radial_load_n": float(np.exp(np.log(g.radial_load_n).mean())),
                "epsilon": float(g.epsilon.mean()),
                "clearance_m": float(g.clearance_m.mean()),
                "clearance_sd": float(g.clearance_m.std()),
                "clearance_half_m": float(((g.clearance_m_high - g.clearance_m_low) / 2).mean()),
                "regime_classifier": max(probs, key=probs.get),
                "windows_regime": list(g.regime),
            }
        )
    return pd.DataFrame(out)


def summary(comb: pd.DataFrame, states: pd.DataFrame) -> pd.DataFrame:
    """Per fidelity and kind: F_r, epsilon and clearance errors of the combined estimates,
    regime right by the windows, the combined classifier and the combined clearance."""
    from signatelec.physics.regimes import regime_of

    truth = states.set_index("state")
    rows = []
    for (fid, kind), g in comb.groupby(["fidelity", "kind"]):
        t = truth.loc[g.state]
        ferr = g.radial_load_n.to_numpy() / t.radial_load_n.to_numpy() - 1
        cl = g.clearance_m.to_numpy() - t.clearance_m.to_numpy()
        by_cl = np.array([regime_of(c) for c in g.clearance_m])
        regimes = t.regime.to_numpy()
        win = [np.mean(np.array(w) == r) for w, r in zip(g.windows_regime, regimes, strict=True)]
        rows.append(
            {
                "fidelity": fid,
                "windows": kind,
                "Fr_mae_pct": 100 * np.abs(ferr).mean(),
                "Fr_within_1pct": float((np.abs(ferr) <= 0.01).mean()),
                "Fr_max_pct": 100 * np.abs(ferr).max(),
                "epsilon_mae": float(np.abs(g.epsilon.to_numpy() - t.epsilon.to_numpy()).mean()),
                "clearance_mae_um": 1e6 * float(np.abs(cl).mean()),
                "regime_windows": float(np.mean(win)),
                "regime_classifier": float((g.regime_classifier.to_numpy() == regimes).mean()),
                "regime_by_clearance": float((by_cl == regimes).mean()),
            }
        )
    return pd.DataFrame(rows)


def state_table(model, feats: pd.DataFrame) -> pd.DataFrame:
    """Combined estimates per state, fidelity and kind of window, and of the mean features."""
    comb = combine(estimates(model, feats))
    noisy = feats[feats.kind == "noisy"]
    meanf = noisy.groupby(["state", "fidelity"])[model.features].mean().reset_index()
    meanf["kind"], meanf["draw"] = "mean features", 0
    return pd.concat([comb, combine(estimates(model, meanf))], ignore_index=True)


def markdown(frame: pd.DataFrame) -> list[str]:
    cols = list(frame.columns)
    out = ["| " + " | ".join(cols) + " |", "|" + " --- |" * len(cols)]
    for row in frame.itertuples(index=False):
        cells = (f"{v:.4g}" if isinstance(v, float) else str(v) for v in row)
        out.append("| " + " | ".join(cells) + " |")
    return out


def models(log) -> dict:
    """The load-state models compared: half and all of the fast-preset runs of the shipped
    table (all: the first default model's load state), those and the paper-fidelity runs of
    the uniform design (the second), and the default model (with the placed runs too)."""
    from signatelec.estimation.models import LoadStateEstimator
    from signatelec.estimation.persistence import default_model
    from signatelec.estimation.training import (
        DEFAULT_TABLE,
        default_training_table,
        train_model,
    )
    from signatelec.studies.load_state import PAPER_RUN_ID_OFFSET

    fast = pd.read_parquet(DEFAULT_TABLE)
    runs = np.sort(fast.run_id.unique())
    half = np.random.default_rng(0).choice(runs, runs.size // 2, replace=False)
    both = default_training_table()
    # the paper-fidelity runs of the uniform design (datasets/load_state_paper.toml) alone
    uniform = both[both.run_id < 2 * PAPER_RUN_ID_OFFSET]
    out = {}
    for name, table in (
        ("600 fast runs", fast[fast.run_id.isin(half)]),
        ("1200 fast runs", fast),
        ("1200 fast + 1200 paper runs", uniform),
    ):
        log(f"training on {name}")
        out[name] = train_model(table, estimator=LoadStateEstimator())
    out["1200 fast + 1800 paper runs (default)"] = default_model(log=log)
    return out


def main(argv=None):
    from signatelec.studies.monitor_records import CALIBRATION_STATES, DESIGN_SEED, dem_bank

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bank", default="/tmp/monitor-bank/design")
    p.add_argument("--out", default="out/monitor_bias")
    p.add_argument("--report", default="docs/monitor/model_error.md")
    p.add_argument("--draws", type=int, default=12)
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    bank = dem_bank(args.bank, print, CALIBRATION_STATES, DESIGN_SEED)
    cache = out / f"bias_features-{args.draws}.parquet"
    if cache.is_file():
        feats = pd.read_parquet(cache)
    else:
        fast = fast_bank(bank, out)
        feats = pd.concat(
            [
                windows_of(bank, list(bank.resistance), "paper", args.draws, 1),
                windows_of(bank, fast, "fast", args.draws, 1),
            ],
            ignore_index=True,
        )
        feats.to_parquet(cache)
    truth = bank.set_index("state")
    tables, lines = [], []
    for name, model in models(print).items():
        comb = state_table(model, feats)
        comb.insert(0, "model", name)
        comb.drop(columns="windows_regime").to_parquet(out / f"states-{len(tables)}.parquet")
        t = summary(comb, bank)
        t.insert(0, "model", name)
        tables.append(t)
        clean = comb[comb.kind == "clean"].pivot(index="state", columns="fidelity")
        d_fr = np.log(clean.radial_load_n.paper / clean.radial_load_n.fast)
        d_cl = clean.clearance_m.paper - clean.clearance_m.fast
        noisy = comb[(comb.kind == "noisy") & (comb.fidelity == "paper")].set_index("state")
        cerr = (noisy.clearance_m - truth.clearance_m).abs()
        dist = (truth.clearance_m.abs() - 1e-6).abs()
        wrong = noisy.index[noisy.regime_classifier != truth.regime.loc[noisy.index]]
        lines.append(
            f"- {name}: paper - fast estimate of a state (clean windows): log F_r "
            f"{d_fr.mean():+.4f} mean, {d_fr.abs().mean():.4f} mean abs; clearance "
            f"{1e6 * d_cl.mean():+.2f} um mean, {1e6 * d_cl.abs().mean():.2f} um mean abs. "
            f"Regime wrong (paper, noisy windows combined) for {len(wrong)} states: "
            + ", ".join(
                f"{truth.regime[s]} at {1e6 * truth.clearance_m[s]:+.1f} um "
                f"(epsilon {truth.epsilon[s]:.3f}) called {noisy.regime_classifier[s]}"
                for s in wrong
            )
            + f"; states within their own clearance error of the +-1 um boundary: "
            f"{int((dist < cerr).sum())} of {len(truth)}."
        )
    table = pd.concat(tables, ignore_index=True)
    table.to_parquet(out / "summary.parquet")
    fm = feats[feats.kind == "clean"].groupby(["state", "fidelity"])[list(FEATURES)].mean()
    rel = (fm.xs("paper", level=1) / fm.xs("fast", level=1) - 1).abs().median()
    text = "\n".join(
        [
            *header(table, len(bank), args.draws),
            "## Method",
            "",
            "Written by `python pipelines/monitor_bias.py` (its docstring says how). The "
            f"{len(bank)} design states of `signatelec study monitor` (not its acceptance "
            f"states), {args.draws} windows of 0.2 s per state and fidelity at random offsets "
            "of the whole-pass tiling, with 0.2 % white noise (`noisy`) and without (`clean`); "
            "a state's windows combined as a stretch's are (mean of log F_r, epsilon and "
            "clearance; summed regime log-probabilities), or the model asked once about the "
            "mean of the noisy windows' features (`mean features`). `paper`: the bank's runs "
            "(velocity Verlet, dt = 1e-7 s); `fast`: the same states at the `fast` preset the "
            "training runs use (held out at the training fidelity: the model's own error). "
            "Regime by clearance: the regime of the combined clearance estimate "
            "(`signatelec.physics.regimes.regime_of`).",
            "",
            *markdown(table.round(4)),
            "",
            *lines,
            "",
            "Median |paper / fast - 1| of the clean windows' features over the states: "
            + ", ".join(f"{k} {v:.3g}" for k, v in rel.items())
            + ".",
            "",
        ]
    )
    Path(args.report).write_text(text)
    print(text)
    return table


def header(table: pd.DataFrame, n_states: int, draws: int) -> list[str]:
    """Title and the findings, read off ``table`` (paper-fidelity states, noisy windows)."""
    t = table.set_index(["model", "fidelity", "windows"])
    names = list(dict.fromkeys(table.model))
    old, uniform, new = names[1], names[2], names[-1]

    def at(model, fid, kind, col):
        return float(t.loc[(model, fid, kind), col])

    def pct(x):
        return f"{100 * x:.1f} %"

    def row(model, fid, kind):
        return (
            f"F_r within 1 % for {pct(at(model, fid, kind, 'Fr_within_1pct'))} "
            f"(mean {at(model, fid, kind, 'Fr_mae_pct'):.3f} %), regime right for "
            f"{pct(at(model, fid, kind, 'regime_classifier'))}"
        )

    return [
        "# The monitor's per-state error: where it comes from",
        "",
        f"On the {n_states} design states of the monitoring study, a stretch's estimate "
        f"(its windows combined) of the first default model ({old}): "
        f"{row(old, 'paper', 'noisy')}.",
        "",
        f"1. **Fidelity mismatch: not the cause.** The same states run at the `fast` preset "
        f"the model trains on: {row(old, 'fast', 'noisy')}; no better than at the paper's "
        "fidelity. The error is the model's own on states it has not seen, at its training "
        "fidelity. The features do differ between the fidelities (the cage slip above all: "
        "the fast preset's cage balls are 80x heavier; list at the end), and a model that "
        "learns from both reads the paper-fidelity states better than the fast ones: clean "
        f"windows, paper {row(new, 'paper', 'clean')}; fast {row(new, 'fast', 'clean')}.",
        f"2. **Noise: a small part.** Clean windows: {row(old, 'paper', 'clean')}; the model "
        f"asked about the noisy windows' mean features: {row(old, 'paper', 'mean features')}. "
        "Averaging the features before the model recovers little of the gap to clean windows, "
        "so the stretch keeps the mean of its window estimates.",
        "3. **The regime boundary.** The regime of the combined clearance estimate is right "
        f"for {pct(at(old, 'paper', 'noisy', 'regime_by_clearance'))} against "
        f"{pct(at(old, 'paper', 'noisy', 'regime_classifier'))} for the combined classifier: "
        "the classifier stays. The regime errors (listed below) lie at the fold of R(epsilon) "
        "near epsilon 0.35 and the vanishing first harmonic near 0.535 (docs/load_state), "
        "and within about 0.5 um of the +-1 um boundary.",
        "4. **Capacity: the main part, with the fidelity of the runs added.** With half of "
        "the fast runs: "
        f"{row(names[0], 'paper', 'noisy')}. With 1200 paper-fidelity runs of the same "
        f"design beside the 1200 fast ones (the second default model): "
        f"{row(uniform, 'paper', 'noisy')}; the fold and harmonic-null states are right, the "
        "errors left lie near the regime boundary. 1200 more paper-fidelity runs of that "
        "design (measured once on these windows, not by this script) left the same four "
        "states wrong and F_r within 1 % for one state more.",
        "5. **Separable, and learnt where the runs are placed.** The misread states differ from "
        "their nearest twins of the competing regime by 5-23 noise standard deviations of a "
        "2 s stretch's mean features, 2-9 times the spread of the same state's runs "
        "([twins.md](twins.md), `pipelines/monitor_twins.py`): the trace tells them apart, "
        "the uniform design was too thin there. 600 paper-fidelity runs placed there "
        "(`datasets/load_state_paper_boundary.toml`: within 6 um of the +-1 um boundaries, "
        "at the fold near epsilon 0.35 and the first-harmonic null near 0.53-0.56) beside "
        f"the others (the default model now): {row(new, 'paper', 'noisy')}.",
        "",
        f"The tables: {draws} windows per state and fidelity; `regime_windows` the share of "
        "single windows right, `regime_classifier` the windows' log-probabilities summed, "
        "`regime_by_clearance` the regime of the mean clearance.",
        "",
    ]


#: Features whose fidelity difference the report lists.
FEATURES = ("level_mean_ohm", "h1_rel", "h2_rel", "h3_rel", "ripple_crest", "ball_pass_slip")


if __name__ == "__main__":
    main()
