"""How far the default condition model's probabilities can be taken at their word on held-out
paper-fidelity runs, and what prior they carry.

Usage::

    python pipelines/condition_reliability.py --work DIR [--report DIR]

``--work``: a diagnosis study's work directory (``signatelec study diagnosis`` or
``pipelines/diagnosis.py`` writes it): the held-out test runs of each bearing under
``runs_<bearing>/test`` (DEM at the paper's fidelity, 40 healthy, 15 per spall location and 10
unbalanced runs per bearing, seeds of their own). Each run is measured as the study's acceptance
windows are (3 draws of 0.2 % white noise over the whole 0.2 s) and asked of the default model's
condition model (trained on the "fast" preset, its probabilities temperature-scaled out of fold
on its training runs). None of these runs took part in the fit.

A classifier's probabilities are posteriors under the mix of classes it learnt from: here the
training design's, healthy, outer, inner, ball and unbalance as 240 : 240 : 240 : 240 : 120
(``info["classes"]`` of the model). The test runs hold them as 40 : 15 : 15 : 15 : 10, so the
probabilities are scored three ways: the model's probabilities with each window weighted by its
condition's share in the design over its share in the test runs (the test runs as if drawn in
the design's mix), unweighted (the test runs' own mix), and, unweighted, the probabilities moved
to the test runs' mix by Bayes' rule (p_k pi'_k / pi_k, renormalised: Saerens, Latinne and
Decaestecker, Neural Computation 14 (2002) 21-41). Measured: the multiclass Brier score, the log
loss, the top-label expected calibration error (bins of the largest probability:
:data:`BINS`), the accuracy of the most probable condition and of the call (the model's rule:
healthy unless the probability of healthy falls below its false-alarm threshold), the mean
probability given to the true condition, the median probability of healthy of the healthy and
of the faulty windows. Writes ``reliability.md``, ``reliability.png`` and
``reliability.parquet`` (one row per window) into the report directory (default
``docs/diagnosis``).
"""

from __future__ import annotations

import argparse
import io
import time
from pathlib import Path

import numpy as np
import pandas as pd
from monitor_bias import markdown

ROOT = Path(__file__).resolve().parents[1]
#: Edges of the bins of the largest probability (top-label reliability).
BINS = (0.0, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 1.0)
#: The three scorings (module docstring).
KINDS = {
    "design": "model, test runs weighted to the design's mix",
    "test": "model, test runs' own mix",
    "test_prior": "moved to the test runs' mix (Bayes), test runs' own mix",
}


def windows(work: Path, model, log=print) -> pd.DataFrame:
    """The acceptance windows of every bearing's test runs with the condition ``model``'s call
    and probabilities."""
    from signatelec.studies.diagnosis import ACCEPT_DRAWS, ACCEPT_KEY, BEARINGS, measured_rows
    from signatelec.studies.load_state import fixed_draw, load_runs
    from signatelec.studies.load_state_metrics import ACCEPT_NOISE

    parts = []
    for bearing in BEARINGS:
        d = work / f"runs_{bearing}" / "test"
        if not d.is_dir():
            log(f"{d}: no test runs, {bearing} skipped")
            continue
        t0 = time.perf_counter()
        runs = load_runs(d, log)
        rows = pd.DataFrame(
            measured_rows(runs, bearing, ACCEPT_DRAWS, fixed_draw(ACCEPT_NOISE), ACCEPT_KEY)
        )
        keep = ["run_id", "bearing", "window", "condition", "radial_load_n", "omega_rad_s"]
        out = rows[keep].rename(columns={"condition": "truth"})
        out["truth"] = out["truth"].astype(str)
        pred = model.estimator.predict_frame(rows[model.features])
        parts.append(pd.concat([out.reset_index(drop=True), pred], axis=1))
        log(f"{bearing}: {len(out)} windows of {len(runs)} runs, {time.perf_counter() - t0:.0f} s")
    return pd.concat(parts, ignore_index=True)


def probabilities(table: pd.DataFrame, kind: str, model):
    """(conditions, probabilities, weights) of one scoring (module docstring)."""
    from signatelec.estimation.condition import PROBABILITY

    design = model.training_mix
    here = table["truth"].value_counts(normalize=True).to_dict()
    if kind == "test_prior":
        table = model.move_to_prior(table, here)
    classes = list(design)
    p = table[[f"{PROBABILITY}{c}" for c in classes]].to_numpy(float)
    w = np.ones(len(table))
    if kind == "design":
        w = table["truth"].map(lambda c: design[c] / here[c]).to_numpy(float)
    return classes, p, w / w.mean()


def scores(table: pd.DataFrame, kind: str, model) -> tuple[dict, pd.DataFrame]:
    """The reliability figures of one scoring (module docstring), and its
    :func:`top_label_bins`."""
    classes, p, w = probabilities(table, kind, model)
    truth = table["truth"].to_numpy(str)
    y = (truth[:, None] == np.array(classes)[None, :]).astype(float)
    top = p.max(axis=1)
    right = p.argmax(axis=1) == y.argmax(axis=1)
    b = top_label_bins(top, right, w)
    p_true = (p * y).sum(axis=1)
    healthy = truth == "healthy"
    h = classes.index("healthy")
    figures = {
        "scoring": KINDS[kind],
        "windows": int(len(table)),
        "brier": float(np.average(((p - y) ** 2).sum(axis=1), weights=w)),
        "log_loss": float(np.average(-np.log(np.clip(p_true, 1e-12, 1.0)), weights=w)),
        "top_label_ece": float(np.sum(b["weight"] * np.abs(b["mean_top"] - b["share_right"]))),
        "most_probable_right": float(np.average(right, weights=w)),
        "call_right": float(np.average(table["condition"].to_numpy(str) == truth, weights=w)),
        "mean_p_true": float(np.average(p_true, weights=w)),
        "p_healthy_of_healthy_median": float(np.median(p[healthy, h])),
        "p_healthy_of_faults_median": float(np.median(p[~healthy, h])),
    }
    return figures, b.assign(scoring=KINDS[kind])


def top_label_bins(top: np.ndarray, right: np.ndarray, w: np.ndarray) -> pd.DataFrame:
    """Per bin of the largest probability (:data:`BINS`): windows, their share of the weight,
    the weighted mean largest probability and share of windows whose most probable condition
    is right."""
    idx = np.clip(np.digitize(top, BINS) - 1, 0, len(BINS) - 2)
    rows = []
    for k in range(len(BINS) - 1):
        s = idx == k
        if s.any():
            rows.append(
                {
                    "bin": f"{BINS[k]:.2f}-{BINS[k + 1]:.2f}",
                    "windows": int(s.sum()),
                    "weight": float(w[s].sum() / w.sum()),
                    "mean_top": float(np.average(top[s], weights=w[s])),
                    "share_right": float(np.average(right[s], weights=w[s])),
                }
            )
    return pd.DataFrame(rows)


def figure(bins: pd.DataFrame, path: Path) -> None:
    """Reliability diagram: the share right against the mean largest probability per bin."""
    import matplotlib.pyplot as plt

    from signatelec.plots import save_figure

    fig, ax = plt.subplots(figsize=(5.6, 4.8))
    ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
    for (name, part), marker in zip(bins.groupby("scoring", sort=False), "os^", strict=False):
        ax.plot(part["mean_top"], part["share_right"], marker=marker, label=name)
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("largest condition probability (bin mean)")
    ax.set_ylabel("share of windows whose most probable condition is right")
    ax.set_title("Condition probabilities, held-out paper-fidelity runs", fontsize=10)
    ax.legend(loc="lower right", fontsize=7)
    save_figure(fig, path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", required=True, help="a diagnosis study's work directory")
    parser.add_argument("--report", default=str(ROOT / "docs" / "diagnosis"), help="report dir")
    args = parser.parse_args(argv)
    from signatelec.estimation.persistence import default_model
    from signatelec.io import write_bytes_atomic

    report = Path(args.report)
    report.mkdir(parents=True, exist_ok=True)
    model = default_model().condition
    table = windows(Path(args.work), model)
    parts = [("both", table), *table.groupby("bearing")]
    rows, bins = [], []
    for b, part in parts:
        for k in KINDS:
            figures, kind_bins = scores(part, k, model)
            rows.append({"bearing": b} | figures)
            if b == "both":
                bins.append(kind_bins)
    summary = pd.DataFrame(rows)
    bins = pd.concat(bins, ignore_index=True)
    mix = ", ".join(f"{c} {v:.3f}" for c, v in model.training_mix.items())
    lines = [
        "# Condition probabilities on held-out paper-fidelity runs",
        "",
        "Written by `python pipelines/condition_reliability.py --work DIR` (its docstring",
        "says how): the diagnosis study's held-out test runs of both bearings, 3 acceptance",
        f"windows each (0.2 % noise). The model's training mix of conditions: {mix}.",
        "",
        *markdown(summary),
        "",
        "## Reliability of the largest probability (both bearings)",
        "",
        *markdown(bins[["scoring", "bin", "windows", "weight", "mean_top", "share_right"]]),
        "",
        "![reliability](reliability.png)",
        "",
    ]
    figure(bins, report / "reliability.png")
    buf = io.BytesIO()
    table.to_parquet(buf, index=False)
    write_bytes_atomic(report / "reliability.parquet", buf.getvalue())
    write_bytes_atomic(report / "reliability.md", "\n".join(lines).encode())
    print("\n".join(lines[5:]))


if __name__ == "__main__":
    main()
