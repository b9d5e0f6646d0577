"""The diagnosis study's report: acceptance table, detection curves, the README's signatures.

Written by :func:`signatelec.studies.diagnosis.run_study` into docs/diagnosis:
``diagnosis.parquet`` (every figure of the tables, the false alarms and the load state with a
defect of :mod:`signatelec.studies.diagnosis_alarms` among them), ``diagnosis.md``,
``diagnosis.png`` (detection probability against spall length and against noise) and
``signatures.png`` (per condition, the resistance over a few cage revolutions and its envelope
spectrum with the characteristic lines marked).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.ticker import NullFormatter

from signatelec.config.catalogue import catalogue_bearing
from signatelec.config.constraints import HEALTHY
from signatelec.config.scene import Scene
from signatelec.estimation.condition import CONDITIONS, SPALLS
from signatelec.io import write_bytes_atomic
from signatelec.plots import new_figure, save_figure
from signatelec.studies.diagnosis_alarms import bootstrap_run_mean

#: Bins of spall length over the Hertz contact width for the detection curve.
RATIO_BINS = (0.1, 0.25, 0.5, 1.0, 2.0, 4.0, 10.0)


def _rate(mask: np.ndarray) -> float:
    return float(np.mean(mask)) if mask.size else float("nan")


def _finite_mean(x: np.ndarray) -> float:
    """Mean of the finite values (NaN without any: rows no load-state model answered)."""
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else float("nan")


def group_figures(rows: pd.DataFrame) -> dict:
    """Detection figures of one group of test rows (module docstring of the study)."""
    cond = rows["condition"].astype(str).to_numpy()
    pred = rows["pred_condition"].astype(str).to_numpy()
    ratio = (rows["spall_length_m"] / rows["hertz_width_m"]).to_numpy()
    healthy = cond == HEALTHY
    spall = np.isin(cond, SPALLS)
    wide = spall & (ratio >= 1.0)
    narrow = spall & (ratio < 1.0)
    unbalance = cond == "unbalance"
    fr = rows["radial_load_n"].to_numpy()
    ape = np.abs(rows["pred_load_radial_load_n"].to_numpy() / fr - 1.0)
    return {
        "windows": int(len(rows)),
        "healthy": int(healthy.sum()),
        "healthy_flagged": _rate(pred[healthy] != HEALTHY),
        "spalls_wide": int(wide.sum()),
        "wide_detected": _rate(pred[wide] != HEALTHY),
        "wide_type_right": _rate(pred[wide] == cond[wide]),
        "spalls_narrow": int(narrow.sum()),
        "narrow_detected": _rate(pred[narrow] != HEALTHY),
        "narrow_type_right": _rate(pred[narrow] == cond[narrow]),
        "unbalance": int(unbalance.sum()),
        "unbalance_right": _rate(pred[unbalance] == "unbalance"),
        "accuracy": _rate(pred == cond),
        "fr_mape_healthy": _finite_mean(ape[healthy]),
        "fr_mape_spall": _finite_mean(ape[spall]),
        "fr_mape_unbalance": _finite_mean(ape[unbalance]),
    }


def figures_table(pred: pd.DataFrame) -> pd.DataFrame:
    """Every figure of the report, one row per (table, group)."""
    rows = []
    acc = pred[pred["acceptance"]]
    for bearing, g in [("all", acc), *acc.groupby("bearing", observed=True)]:
        rows.append({"table": "acceptance", "group": str(bearing), **group_figures(g)})
    for noise, g in pred.groupby("scan_noise"):
        rows.append({"table": "noise", "group": f"{noise:g}", **group_figures(g)})
    spall = acc[acc["condition"].isin(SPALLS)]
    ratio = spall["spall_length_m"] / spall["hertz_width_m"]
    cut = pd.cut(ratio, RATIO_BINS)
    for (interval, condition), g in spall.groupby([cut, "condition"], observed=True):
        detected = (g["pred_condition"] != HEALTHY).to_numpy()
        rows.append(
            {
                "table": "length",
                "group": f"{condition} {interval.left:g}-{interval.right:g}",
                "windows": int(len(g)),
                "wide_detected": _rate(detected),
                "wide_type_right": _rate((g["pred_condition"] == g["condition"]).to_numpy()),
            }
        )
    return pd.DataFrame(rows)


def length_figures(pred: pd.DataFrame) -> pd.DataFrame:
    """The spall-length estimate on the acceptance windows whose spall was detected and typed
    right, per location and for all: windows, median and mean relative error, the share of
    true lengths inside the interval (nominal 90 %) with its bootstrap 95 % interval over the
    runs (``coverage_low``, ``coverage_high``)."""
    acc = pred[pred["acceptance"] & pred["condition"].isin(SPALLS)]
    acc = acc[acc["pred_condition"] == acc["condition"]]
    rows = []
    rng = np.random.default_rng(14)
    for group, g in [("all", acc), *acc.groupby("condition", observed=True)]:
        truth = g["spall_length_m"].to_numpy()
        err = np.abs(g["pred_spall_length_m"].to_numpy() / truth - 1.0)
        inside = (g["pred_spall_length_m_low"] <= truth) & (truth <= g["pred_spall_length_m_high"])
        by_run = [v.to_numpy(dtype=float) for _, v in inside.groupby(g["run_id"])]
        lo, hi = (
            np.percentile(bootstrap_run_mean(by_run, rng), [2.5, 97.5]) if by_run else (np.nan,) * 2
        )
        rows.append(
            {
                "group": str(group),
                "windows": int(len(g)),
                "runs": len(by_run),
                "median_error": float(np.median(err)) if err.size else float("nan"),
                "mean_error": _rate(err),
                "coverage": _rate(inside.to_numpy()),
                "coverage_low": float(lo),
                "coverage_high": float(hi),
            }
        )
    return pd.DataFrame(rows)


def _pct(x) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{100 * x:.1f} %"


def markdown(table: pd.DataFrame, pred: pd.DataFrame, info: dict) -> str:
    acc = table[table["table"] == "acceptance"]
    lines = [
        "# Diagnosis: the bearing's condition from its resistance",
        "",
        "Written by `signatelec study diagnosis` (signatelec/studies/diagnosis.py). Held-out "
        "DEM runs at the paper's fidelity (velocity Verlet, dt = 1e-7 s, every effect"
        + (", here the quick variant at the fast preset" if info.get("quick") else "")
        + "), each 0.2 s at 20 kHz measured with 0.2 % white noise and 0.05 % drift; the "
        f"condition model trained on {info.get('train_runs', '?')} runs of the fast preset "
        "(datasets/diagnosis.toml, the seed's bearing and the 6205), noise 0.05-1 %.",
        "",
        "A spall is *wide* when its length is at least the Hertz contact width in the rolling "
        "direction (2 a, Hamrock-Brewe, at the run's largest ball load, on its race; a ball's "
        "spall: the wider of its two contacts). *Flagged*: called anything but healthy.",
        "",
        "| bearing | windows | healthy flagged | wide spalls detected | type right | narrow "
        "detected | unbalance right | accuracy | F_r MAPE healthy / spall / unbalance |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in acc.itertuples():
        r = r._replace(
            **{
                k: int(getattr(r, k))
                for k in ("healthy", "spalls_wide", "spalls_narrow", "unbalance")
            }
        )
        lines.append(
            f"| {r.group} | {r.windows} | {_pct(r.healthy_flagged)} of {r.healthy} | "
            f"{_pct(r.wide_detected)} of {r.spalls_wide} | {_pct(r.wide_type_right)} | "
            f"{_pct(r.narrow_detected)} of {r.spalls_narrow} | {_pct(r.unbalance_right)} of "
            f"{r.unbalance} | {_pct(r.accuracy)} | {_pct(r.fr_mape_healthy)} / "
            f"{_pct(r.fr_mape_spall)} / {_pct(r.fr_mape_unbalance)} |"
        )
    lines += [
        "",
        "F_r by the default load-state model as `signatelec estimate` answers: where the "
        "condition model calls healthy, its healthy model (the load-state study's runs); where "
        "it calls a fault, its faulty model (the condition model's training runs of the seed's "
        "bearing alone, healthy, spalled and unbalanced). The 6205 rows have none (the "
        "load-state models know the seed's bearing only). Under an unbalance F_r is the static "
        "load.",
        "",
        "## Detection against noise (every test run measured again at each noise level)",
        "",
        "| noise | healthy flagged | wide detected | type right | narrow detected | accuracy |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in table[table["table"] == "noise"].itertuples():
        lines.append(
            f"| {float(r.group) * 100:g} % | {_pct(r.healthy_flagged)} | "
            f"{_pct(r.wide_detected)} | {_pct(r.wide_type_right)} | "
            f"{_pct(r.narrow_detected)} | {_pct(r.accuracy)} |"
        )
    lines += [
        "",
        "## Detection against spall length (acceptance windows)",
        "",
        "| spall, length / contact width | windows | detected | type right |",
        "| --- | --- | --- | --- |",
    ]
    for r in table[table["table"] == "length"].itertuples():
        lines.append(
            f"| {r.group} | {r.windows} | {_pct(r.wide_detected)} | {_pct(r.wide_type_right)} |"
        )
    lines += [
        "",
        "## Spall length (acceptance windows detected and typed right)",
        "",
        "The 90 % interval's margin is set per spall location by split conformal prediction on "
        f"{info.get('calibration_runs', '?')} further held-out runs at the paper's fidelity "
        "(their own seed, each measured twice at 0.05-1 % noise), not on the fast preset's "
        f"training runs, on which the model errs less: {info.get('calibration', '?')}. The "
        "acceptance runs below are few (15 per location and bearing): their coverage comes "
        "with a wide interval.",
        "",
        "| spall | runs | windows | median error | mean error | true length inside the 90 % "
        "interval | 95 % interval over runs |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in length_figures(pred).itertuples():
        lines.append(
            f"| {r.group} | {r.runs} | {r.windows} | {_pct(r.median_error)} | "
            f"{_pct(r.mean_error)} | {_pct(r.coverage)} | {_pct(r.coverage_low)} - "
            f"{_pct(r.coverage_high)} |"
        )
    cm = pd.crosstab(
        pred.loc[pred["acceptance"], "condition"], pred.loc[pred["acceptance"], "pred_condition"]
    )
    lines += ["", "## Confusion (acceptance windows; rows true, columns called)", ""]
    cols = [c for c in CONDITIONS if c in cm.columns]
    lines.append("| true \\ called | " + " | ".join(cols) + " |")
    lines.append("| --- |" + " --- |" * len(cols))
    for c in CONDITIONS:
        if c in cm.index:
            lines.append(f"| {c} | " + " | ".join(str(int(cm.loc[c, k])) for k in cols) + " |")
    lines += [
        "",
        f"Condition model fitted in {info.get('fit_cpu_s', float('nan')):.0f} s of CPU; the "
        f"study took {info.get('elapsed_s', float('nan')) / 60:.1f} min (runs cached in its "
        "output directory).",
        "",
    ]
    return "\n".join(lines)


def plot_curves(table: pd.DataFrame, path: Path) -> None:
    """Detection probability against spall length (over the contact width) and against
    noise."""
    fig = new_figure(12, 4.5)
    ax = fig.subplots(1, 2)
    length = table[table["table"] == "length"]
    for condition in SPALLS:
        g = length[length["group"].str.startswith(condition + " ")]
        if g.empty:
            continue
        mids = [np.sqrt(np.prod([float(x) for x in s.split()[1].split("-")])) for s in g["group"]]
        ax[0].plot(mids, g["wide_detected"], "o-", label=condition)
    ax[0].axvline(1.0, color="k", lw=0.8, ls="--")
    for a in ax:
        a.xaxis.set_minor_formatter(NullFormatter())
    ax[0].set(
        xscale="log",
        ylim=(-0.02, 1.02),
        xlabel="spall length / Hertz contact width",
        ylabel="detection probability",
        title="held-out DEM runs, 0.2 % noise, 0.2 s",
    )
    ax[0].legend()
    noise = table[table["table"] == "noise"]
    x = noise["group"].astype(float) * 100
    ax[1].plot(x, noise["wide_detected"], "o-", label="spalls >= contact width detected")
    ax[1].plot(x, noise["wide_type_right"], "s-", label="their type right")
    ax[1].plot(x, noise["healthy_flagged"], "^-", label="healthy runs flagged")
    ax[1].set(
        xscale="log",
        ylim=(-0.02, 1.02),
        xlabel="white noise (% of the level)",
        ylabel="probability",
        title="against noise (same runs, 0.2 s)",
    )
    ax[1].legend()
    save_figure(fig, path)


def plot_signatures(runs: pd.DataFrame, path: Path, noise: float = 2e-3) -> None:
    """Per condition (rows): the resistance over three cage revolutions and its envelope
    spectrum with the characteristic lines marked (seed's bearing, 0.2 % noise)."""
    from signatelec.estimation.envelope import LINES, analyse_envelope

    colours = dict(
        zip(LINES, ("tab:purple", "tab:brown", "tab:blue", "tab:red", "tab:green"), strict=True)
    )
    fig = new_figure(12, 2.2 * len(runs))
    ax = fig.subplots(len(runs), 2, squeeze=False)
    rng = np.random.default_rng(0)
    for i, run in enumerate(runs.itertuples(index=False)):
        b = Scene().bearing if run.bearing == "seed" else catalogue_bearing(run.bearing)
        clean = np.asarray(run.resistance_clean_ohm, dtype=float)
        r = clean * (1.0 + noise * rng.standard_normal(clean.size))
        fs, omega = float(run.sample_rate_hz), float(run.omega_rad_s)
        a = analyse_envelope(r, fs, omega, bearing=b)
        n = min(r.size, int(3.0 / a.lines_hz["ftf"] * fs))
        t_ms = np.arange(n) / fs * 1e3
        ax[i, 0].plot(t_ms, r[:n] * 1e3, lw=0.6, color="k")
        what = run.condition
        if run.condition in SPALLS:
            what += f", spall {run.spall_length_m * 1e3:.2f} mm x {run.spall_depth_m * 1e6:.0f} um"
        elif run.condition == "unbalance":
            what += f", {run.unbalance_force_n:.0f} N"
        ax[i, 0].set(
            ylabel="R (mOhm)",
            title=f"{what}: F_r {run.radial_load_n:.0f} N, {omega:.0f} rad/s",
        )
        spec = a.envelope
        f = np.arange(spec.amplitude.size) * spec.df_hz
        top = 3.2 * max(a.lines_hz[k] for k in LINES)
        sel = (f > 0) & (f <= top)
        ax[i, 1].plot(f[sel], spec.amplitude[sel] / abs(a.level_ohm), lw=0.6, color="k")
        for name in LINES:
            for k in (1, 2, 3):
                ax[i, 1].axvline(
                    k * a.lines_hz[name],
                    color=colours[name],
                    lw=0.8,
                    ls="-" if k == 1 else ":",
                    label=name if k == 1 and i == 0 else None,
                )
        ax[i, 1].set(ylabel="squared envelope / R", yscale="log")
        if i == 0:
            ax[i, 1].legend(ncol=5, fontsize=7, loc="upper right")
            ax[i, 1].set_title(
                f"envelope spectrum, band {a.band.low_hz:.0f}-{a.band.high_hz:.0f} Hz "
                "(spectral kurtosis)"
            )
    ax[-1, 0].set_xlabel("time (ms)")
    ax[-1, 1].set_xlabel("frequency (Hz)")
    save_figure(fig, path)


def signature_runs(out: Path) -> pd.DataFrame:
    """One seed-bearing test run per condition: the spall nearest 1.5 mm, the largest
    unbalance, the first healthy run."""
    from signatelec.data import read_dataset

    runs = read_dataset(out / "runs_seed" / "test")
    runs = runs[runs["status"] == "ok"]
    picks = []
    for c in CONDITIONS:
        g = runs[runs["condition"] == c]
        if g.empty:
            continue
        if c in SPALLS:
            picks.append(g.iloc[int(np.argmin(np.abs(np.log(g["spall_length_m"] / 1.5e-3))))])
        elif c == "unbalance":
            picks.append(g.iloc[int(np.argmax(g["unbalance_force_n"]))])
        else:
            picks.append(g.iloc[0])
    return pd.DataFrame(picks).assign(bearing="seed")


def report(
    pred: pd.DataFrame,
    report_dir: Path,
    out: Path,
    info: dict,
    model=None,
    alarms: pd.DataFrame | None = None,
) -> dict:
    """Write the report files; returns the acceptance row of all bearings. ``alarms``: the
    false-alarm runs' predictions (:mod:`signatelec.studies.diagnosis_alarms`)."""
    from signatelec.studies import diagnosis_alarms

    report_dir.mkdir(parents=True, exist_ok=True)
    table = figures_table(pred)
    text = markdown(table, pred, info)
    load = diagnosis_alarms.load_error_figures(pred)
    parts = [
        table,
        load.rename(columns={"condition": "group"}).assign(table="load"),
        length_figures(pred).assign(table="spall_length"),
    ]
    if alarms is not None:
        alarm = diagnosis_alarms.alarm_figures(alarms)
        parts.append(alarm.assign(table="alarms"))
        extra = diagnosis_alarms.markdown(alarm, load, bool(info.get("quick")))
        head, tail = text.split("## Detection against noise", 1)
        text = head + "\n".join(extra) + "\n## Detection against noise" + tail
    table = pd.concat(parts, ignore_index=True)
    buf = io.BytesIO()
    table.to_parquet(buf, index=False)
    write_bytes_atomic(report_dir / "diagnosis.parquet", buf.getvalue())
    write_bytes_atomic(report_dir / "diagnosis.md", text.encode())
    plot_curves(table, report_dir / "diagnosis.png")
    plot_signatures(signature_runs(out), report_dir / "signatures.png")
    acc = table[(table["table"] == "acceptance") & (table["group"] == "all")]
    return acc.iloc[0].to_dict()
