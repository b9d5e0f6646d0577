"""The load-state study's report: a figure, a Markdown page, the time of one estimate.

Written by :func:`signatelec.studies.load_state.run_study` into docs/load_state: ``load_state.png``
(:func:`plot_report`), ``load_state.md`` (:func:`write_markdown`) from the metrics of
:mod:`signatelec.studies.load_state_metrics`, and :func:`benchmark`.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.config.scene import Scene
from signatelec.engines.simulate import simulate
from signatelec.estimation.estimate import CONFIDENT_PROBABILITY, estimate
from signatelec.estimation.models import LoadStateModel
from signatelec.estimation.training import model_features
from signatelec.measurement.traces import prepare_trace
from signatelec.physics.regimes import REGIMES
from signatelec.plots import new_figure, save_figure
from signatelec.studies.load_state_metrics import KNOWN_FEATURES, twin_table


def plot_report(cv: pd.DataFrame, table: pd.DataFrame, path: Path) -> None:
    """Predicted against true F_r and epsilon, the confusion matrix of regimes (cross-validated
    acceptance windows), accuracy against noise and length, reliability of the regime
    probabilities."""
    acc = cv[cv["condition"] == "acceptance"]
    fig = new_figure(16, 10)
    ax = fig.subplots(2, 3)
    colours = {"preload": "tab:blue", "zero": "tab:green", "clearance": "tab:red"}
    a = ax[0, 0]
    for regime, g in acc.groupby("regime"):
        a.scatter(
            g["radial_load_n"],
            g["pred_radial_load_n"],
            s=4,
            alpha=0.5,
            color=colours[regime],
            label=regime,
        )
    lim = [acc["radial_load_n"].min() * 0.9, acc["radial_load_n"].max() * 1.1]
    a.plot(lim, lim, "k-", lw=0.8)
    a.set(
        xscale="log",
        yscale="log",
        xlabel="true F_r (N)",
        ylabel="estimated F_r (N)",
        title="radial load (held-out runs, 0.2 % noise, 50 ms)",
    )
    a.legend(markerscale=3)
    a = ax[0, 1]
    for regime, g in acc.groupby("regime"):
        a.scatter(g["epsilon"], g["pred_epsilon"], s=4, alpha=0.5, color=colours[regime])
    a.plot([0.28, 0.62], [0.28, 0.62], "k-", lw=0.8)
    a.set(xlabel="true epsilon", ylabel="estimated epsilon", title="load parameter epsilon")
    a = ax[0, 2]
    cm = pd.crosstab(acc["regime"], acc["pred_regime"]).reindex(
        index=REGIMES, columns=REGIMES, fill_value=0
    )
    frac = cm.to_numpy() / cm.to_numpy().sum(axis=1, keepdims=True)
    a.imshow(frac, cmap="Blues", vmin=0, vmax=1)
    for i in range(3):
        for j in range(3):
            a.text(
                j,
                i,
                f"{cm.iat[i, j]}\n{frac[i, j]:.0%}",
                ha="center",
                va="center",
                color="white" if frac[i, j] > 0.5 else "black",
            )
    a.set(
        xticks=range(3),
        xticklabels=REGIMES,
        yticks=range(3),
        yticklabels=REGIMES,
        xlabel="estimated regime",
        ylabel="true regime",
        title="regimes (held-out runs)",
    )
    for a, cond, x, xlabel in (
        (ax[1, 0], "noise", "noise_fraction", "white noise per sample (% of R)"),
        (ax[1, 1], "length", "length_s", "trace length (ms)"),
    ):
        m = table[(table["source"] == "cv_fast") & (table["condition"] == cond)].sort_values(x)
        t = table[(table["source"] == "test_dem") & (table["condition"] == cond)].sort_values(x)
        scale = 100.0 if cond == "noise" else 1e3
        xs = m[x] * scale
        a.plot(xs, m["fr_mape_pct"], "o-", label="F_r MAPE (%)")
        a.plot(xs, 100 * m["epsilon_mae"], "s-", label="epsilon MAE x 100")
        a.plot(xs, 100 * (1 - m["regime_accuracy"]), "^-", label="regime error (%)")
        if len(t):
            xt = t[x] * scale
            a.plot(xt, t["fr_mape_pct"], "o--", color="C0", alpha=0.5)
            a.plot(xt, 100 * t["epsilon_mae"], "s--", color="C1", alpha=0.5)
            a.plot(
                xt,
                100 * (1 - t["regime_accuracy"]),
                "^--",
                color="C2",
                alpha=0.5,
                label="dashed: paper-fidelity test runs",
            )
        a.axhline(3, color="grey", lw=0.6, ls=":")
        a.axhline(10, color="grey", lw=0.6, ls=":")
        ticks = sorted(set(xs))
        a.set(
            xscale="log",
            xlabel=xlabel,
            ylabel="error",
            title=f"accuracy vs {'noise (50 ms)' if cond == 'noise' else 'length (0.2 % noise)'}",
        )
        a.set_xticks(ticks, [f"{v:g}" for v in ticks])
        a.minorticks_off()
        a.legend(fontsize=8)
    a = ax[1, 2]
    proba = np.stack([acc[f"pred_regime_probability_{r}"] for r in REGIMES], axis=1)
    conf = proba.max(axis=1)
    right = (acc["pred_regime"] == acc["regime"]).to_numpy()
    edges = np.linspace(1 / 3, 1.0, 9)
    idx = np.clip(np.digitize(conf, edges) - 1, 0, len(edges) - 2)
    mids = 0.5 * (edges[1:] + edges[:-1])
    n_bin = np.bincount(idx, minlength=len(mids))
    hit = np.bincount(idx, weights=right, minlength=len(mids))
    ok = n_bin > 0
    a.plot([1 / 3, 1], [1 / 3, 1], "k-", lw=0.8)
    a.plot(mids[ok], hit[ok] / n_bin[ok], "o-", color="C3", label="fraction right")
    a2 = a.twinx()
    a2.bar(mids, n_bin / n_bin.sum(), width=0.07, alpha=0.25, color="grey")
    a2.set_ylabel("share of traces")
    a.set(
        xlabel="probability of the estimated regime",
        ylabel="fraction estimated right",
        title=f"regime probabilities (wrong calls: mean {conf[~right].mean():.2f}, "
        f"right: {conf[right].mean():.2f})",
    )
    a.legend(loc="upper left")
    save_figure(fig, path, dpi=80)


def benchmark(model: LoadStateModel, repeats: int = 20) -> dict:
    """Time to estimate a 1 s trace at 50 kHz (features + model), model loaded."""
    sc = Scene().with_overrides(
        duration_s=0.007 + 1.0, sample_rate_hz=50000.0, fidelity="quasistatic"
    )
    st = simulate(sc).steady()
    r = st["resistance_ohm"].to_numpy()[:50000]
    r = r * (1 + 0.002 * np.random.default_rng(0).standard_normal(r.size))
    t = np.arange(r.size) / 50000.0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        trace = prepare_trace(t, r, 500.0, "benchmark")
        estimate(trace, 500.0, model)
        times.append(time.perf_counter() - t0)
    return {
        "samples": int(r.size),
        "first_s": times[0],
        "median_s": float(np.median(times)),
        "max_s": float(np.max(times)),
        "repeats": repeats,
    }


def write_markdown(
    table: pd.DataFrame,
    bench: dict,
    info: dict,
    path: Path,
    twins: pd.DataFrame | None = None,
    by_epsilon: pd.DataFrame | None = None,
) -> None:
    def row(source, condition):
        m = table[(table["source"] == source) & (table["condition"] == condition)]
        return m.iloc[0] if len(m) else None

    lines = [
        "# Load-state estimation",
        "",
        "Generated by `python pipelines/load_state.py`; see its docstring for the steps.",
        f"Model: `LoadStateEstimator` trained on {info['n_rows']} windows of {info['n_runs']} DEM "
        f"runs; features: {len(model_features())}; fit {info['fit_s']} s.",
        "",
        "## Acceptance: held-out runs, 0.2 % noise, 50 ms at 20 kHz",
        "",
        "| runs | n | F_r MAPE | epsilon MAE | clearance MAE | regime acc. | "
        "F_r / eps / clearance 90 % interval coverage | median width F_r, eps, c |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for source, label in (
        ("cv_fast", "CV, fast preset"),
        ("test_dem", "test, paper fidelity"),
        ("test_dem_default_model", "test, default model"),
    ):
        for cond in ("acceptance", *(f"acceptance:{r}" for r in REGIMES)):
            m = row(source, cond)
            if m is None:
                continue
            lines.append(
                f"| {label} {cond.split(':')[-1] if ':' in cond else 'all'} | {m['n']} | "
                f"{m['fr_mape_pct']:.2f} % | {m['epsilon_mae']:.3f} | "
                f"{m['clearance_mae_um']:.1f} um | {m['regime_accuracy']:.1%} | "
                f"{m['radial_load_n_coverage']:.0%} / {m['epsilon_coverage']:.0%} / "
                f"{m['clearance_m_coverage']:.0%} | {m['radial_load_n_width_median']:.1%}, "
                f"{m['epsilon_width_median']:.3f}, {m['clearance_m_width_median']:.1f} um |"
            )
    lines += ["", "## Sensitivity (cross-validated training runs)", ""]
    lines += [
        "| condition | noise | length | F_r MAPE | eps MAE | regime acc. |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    sens = table[(table["source"] == "cv_fast") & table["condition"].isin(["noise", "length"])]
    for _, m in sens.iterrows():
        lines.append(
            f"| {m['condition']} | {m['noise_fraction']:.2%} | {m['length_s'] * 1e3:g} ms | "
            f"{m['fr_mape_pct']:.2f} % | {m['epsilon_mae']:.3f} | {m['regime_accuracy']:.1%} |"
        )
    if twins is not None and by_epsilon is not None:
        lines += _limits_markdown(table, twins, by_epsilon)
    lines += [
        "",
        f"Estimate of a 1 s trace at 50 kHz (prepare + features + model, model loaded): median "
        f"{bench['median_s'] * 1e3:.1f} ms, first call {bench['first_s'] * 1e3:.1f} ms, "
        f"max {bench['max_s'] * 1e3:.1f} ms over {bench.get('repeats', 20)} calls.",
        "",
        "![report](load_state.png)",
        "",
    ]
    path.write_text("\n".join(lines))


def _limits_markdown(table: pd.DataFrame, twins: pd.DataFrame, by_eps: pd.DataFrame) -> list:
    tt = twin_table(twins)
    close = twins["twin_distance"] < 1.0
    lines = [
        "",
        "## Where the targets are out of reach",
        "",
        "Resistance signatures of different regimes coincide within the noise. For each training "
        "run, the distance to the nearest run of another regime, in units of one 50 ms window's "
        "measurement scatter at 0.2 % noise (RMS over the model's "
        f"{len(model_features()) - len(KNOWN_FEATURES)} signature features; "
        "`signature_twins` in signatelec/studies/load_state_metrics.py; ~0.7 is what noise "
        "alone puts between two 4-window means of one state; below 1 two load states differ by "
        "less than one window's noise). "
        f"{close.mean():.0%} of runs have such a twin closer than 1; the median distance is "
        f"{twins['twin_distance'].median():.2f}. Cross-validated regime accuracy follows the "
        "distance:",
        "",
        "| distance to nearest other-regime signature | runs | share | regime accuracy |",
        "| --- | --- | --- | --- |",
    ]
    for _, m in tt.iterrows():
        lines.append(
            f"| {m['band']} | {m['runs']} | {m['share']:.0%} | {m['regime_accuracy']:.1%} |"
        )
    lines += [
        "",
        "By true epsilon (cross-validated windows): the regime calls fail where the first "
        "ball-pass harmonic vanishes (epsilon ~0.40 and ~0.535) and where R(epsilon) folds "
        "(below ~0.35 R rises again as epsilon falls), so that a clearance at one epsilon "
        "and a preload at another give one signature:",
        "",
        "| true epsilon | windows | regime accuracy | epsilon MAE | runs with a twin < 1 |",
        "| --- | --- | --- | --- | --- |",
    ]
    for _, m in by_eps.iterrows():
        lines.append(
            f"| {m['band']} | {m['windows']} | {m['regime_accuracy']:.1%} | "
            f"{m['epsilon_mae']:.3f} | {m['twinned_runs']:.0%} |"
        )
    lines += [
        "",
        "The estimator says so: a call below "
        f"{CONFIDENT_PROBABILITY:.0%} probability is reported as uncertain, naming the rival "
        "regimes (`regime_confident` in the JSON). At the acceptance condition:",
        "",
        "| runs | confident calls | their accuracy | all calls' accuracy |",
        "| --- | --- | --- | --- |",
    ]
    for source, label in (("cv_fast", "CV, fast preset"), ("test_dem", "test, paper fidelity")):
        m = table[(table["source"] == source) & (table["condition"] == "acceptance")]
        if len(m):
            m = m.iloc[0]
            lines.append(
                f"| {label} | {m['regime_confident_share']:.0%} | "
                f"{m['regime_confident_accuracy']:.1%} | {m['regime_accuracy']:.1%} |"
            )
    return lines


# --- ship ---------------------------------------------------------------------------------------
