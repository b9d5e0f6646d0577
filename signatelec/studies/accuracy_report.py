"""Report of the accuracy-cost study: Markdown tables and the Pareto plot.

:func:`markdown` writes the per-setting summary (worst error over the scenes, median cost) and
the per-scene table of :func:`signatelec.studies.accuracy_cost.run_cases`; :func:`plot` the
error against the CPU cost, log axes, with the Pareto front. Both read the study's table only.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.plots import new_figure, save_figure
from signatelec.studies.accuracy_metrics import (
    COST_FRACTION,
    PAPER_SETTING,
    TOLERANCE,
    cheap_and_accurate,
    pareto_front,
    summarise,
)


def _pct(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{100 * x:.3g} %"


def _num(x: float, fmt: str = ".3g") -> str:
    return "-" if not np.isfinite(x) else format(x, fmt)


def markdown(table: pd.DataFrame, run_time_s: float | None = None) -> str:
    summary = summarise(table)
    lines = [
        "# Accuracy against cost",
        "",
        "Reference: DEM, velocity Verlet, dt = 1e-8 s, every seed effect. Errors are relative to "
        "it, the worst |error| over the scenes; `accuracy` is the larger of the mean resistance "
        "and ball-pass amplitude errors. Costs are medians over the scenes of the time per "
        "simulated second of bearing time (compile excluded; the quasi-static tier: per second "
        "of the steady phase it returns), as wall time and as CPU time of the process; `cost vs "
        "paper` is the CPU time relative to the paper's setting (dt = 1e-7 s, Verlet, every "
        "effect) on the same scene, the steadier measure on a shared machine. The rigid cage is "
        "another model: its rows (`... rigid cage ...`) are compared with its own reference "
        "(`reference rigid cage dt=1e-8`, the same numerics), whose row in turn is compared with "
        "the cage balls' reference, i.e. gives the difference between the two cage models.",
        "",
        "| setting | mean R | ball-pass amp. | accuracy | RMS trace | max ball load | "
        "wall s / sim. s | CPU s / sim. s | cost vs paper | scenes |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary.itertuples():
        lines.append(
            f"| {r.setting} | {_pct(r.mean_resistance_error)} | "
            f"{_pct(r.ball_pass_amplitude_error)} | {_pct(r.accuracy_error)} | "
            f"{_pct(r.rms_resistance_error)} | {_pct(r.max_ball_load_error)} | "
            f"{_num(r.wall_s_per_simulated_s)} | {_num(r.cpu_s_per_simulated_s)} | "
            f"{_num(getattr(r, 'cpu_cost_vs_paper', math.nan))} | "
            f"{r.scenes}{f' ({r.failed} failed)' if r.failed else ''} |"
        )
    if "cpu_cost_vs_paper" in summary:
        found = cheap_and_accurate(summary)
        names = ", ".join(f"`{n}`" for n in found["setting"]) or "none"
        lines += [
            "",
            f"DEM settings within {100 * TOLERANCE:g} % on mean R and ball-pass amplitude at "
            f"<= 1/{1 / COST_FRACTION:g} of the paper's cost: {names}.",
        ]
    lines += [
        "",
        "## Per scene",
        "",
        "| scene | setting | dt (s) | dt / limit | mean R (mOhm) | mean R err | ball-pass amp. "
        "(uOhm) | amp. err | RMS err | max load (N) | load err | wall s / sim. s | "
        "CPU s / sim. s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table.itertuples():
        if r.status != "ok":
            lines.append(f"| {r.scene} | {r.setting} | | | {r.status} | | | | | | | | |")
            continue
        lines.append(
            f"| {r.scene} | {r.setting} | {_num(r.dt_s)} | {_num(r.dt_over_limit, '.2f')} | "
            f"{1e3 * r.mean_resistance_ohm:.5f} | {_pct(r.mean_resistance_error)} | "
            f"{1e6 * r.ball_pass_amplitude_ohm:.4g} | {_pct(r.ball_pass_amplitude_error)} | "
            f"{_pct(r.rms_resistance_error)} | {r.max_ball_load_n:.1f} | "
            f"{_pct(r.max_ball_load_error)} | {_num(r.wall_s_per_simulated_s)} | "
            f"{_num(r.cpu_s_per_simulated_s)} |"
        )
    if run_time_s is not None:
        lines += ["", f"Study run time: {run_time_s:.0f} s (sum of the cases' wall times)."]
    return "\n".join(lines) + "\n"


_FAMILIES = (
    ("quasistatic", "quasi-static tier", "tab:purple"),
    ("preset", "preset", "tab:red"),
    ("cage mass", "DEM, cage mass scaled", "tab:orange"),
    ("rigid", "DEM, rigid cage (vs its own reference)", "tab:green"),
    ("euler", "DEM, symplectic Euler", "tab:olive"),
    ("law", "DEM, linear / Harris law", "tab:cyan"),
    ("gravity", "DEM, no gravity", "tab:brown"),
    ("", "DEM, velocity Verlet", "tab:blue"),
)


def _family(setting: str) -> tuple[str, str]:
    for key, label, colour in _FAMILIES:
        if key in setting:
            return label, colour
    raise AssertionError(setting)  # pragma: no cover - the last family matches everything


def plot(table: pd.DataFrame, path: Path) -> None:
    """Pareto plot: worst accuracy error (and RMS trace error) against CPU cost, log axes.

    Points are coloured by family; the Pareto front, the presets, the paper's setting and the
    quasi-static tier are labelled (errors of 0, the reference's, are drawn at 1e-6).
    """
    from matplotlib.lines import Line2D

    summary = summarise(table)
    cost = summary["cpu_s_per_simulated_s"].to_numpy()
    names = [n.removeprefix("dem ") for n in summary["setting"]]
    families = [_family(s) for s in summary["setting"]]
    fig = new_figure(13.0, 5.6)
    panels = (
        ("accuracy_error", "worst |error| of mean R and ball-pass amplitude"),
        ("rms_resistance_error", "worst RMS trace difference / mean R"),
    )
    paper = summary[summary["setting"] == PAPER_SETTING]
    for ax, (column, label) in zip(fig.subplots(1, 2), panels, strict=True):
        error = np.maximum(summary[column].to_numpy(), 1e-6)
        ax.scatter(cost, error, c=[c for _, c in families], s=32, zorder=3)
        front = pareto_front(cost, error)
        ax.plot(cost[front], error[front], "k--", lw=0.8, zorder=2)
        keep = set(front.tolist()) | {
            i
            for i, s in enumerate(summary["setting"])
            if s.startswith(("preset", "quasistatic")) or s == PAPER_SETTING
        }
        for k, i in enumerate(sorted(keep, key=lambda i: cost[i])):
            ax.annotate(
                names[i],
                (cost[i], error[i]),
                fontsize=6.5,
                xytext=(4, 6 if k % 2 else -9),
                textcoords="offset points",
            )
        ax.axhline(TOLERANCE, color="tab:red", lw=0.8, ls=":")
        if len(paper):
            ax.axvline(
                COST_FRACTION * float(paper["cpu_s_per_simulated_s"].iloc[0]),
                color="tab:green",
                lw=0.8,
                ls=":",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU time per simulated second (s/s, median over scenes)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    handles = [
        Line2D([], [], ls="", marker="o", color=colour, label=label)
        for _, label, colour in _FAMILIES
    ] + [
        Line2D([], [], color="k", ls="--", lw=0.8, label="Pareto front"),
        Line2D([], [], color="tab:red", ls=":", lw=0.8, label=f"{100 * TOLERANCE:g} %"),
        Line2D(
            [],
            [],
            color="tab:green",
            ls=":",
            lw=0.8,
            label=f"1/{1 / COST_FRACTION:g} of the paper's cost",
        ),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=5, fontsize=7.5)
    fig.suptitle(
        "signatelec: accuracy against cost (5 scenes; reference: DEM, Verlet, dt = 1e-8 s)",
        fontsize=10,
    )
    save_figure(fig, path)
