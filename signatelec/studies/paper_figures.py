"""The seed's figures 6-11 as PNG, drawn from simulation results (matplotlib, Agg, no screen).

Seed section 4 (Machado, Guessasma, Bellenger):

- figures 6 and 9: normal force, current and potential of each ball at one steady instant, for
  F_r = 5820 N at epsilon = 0.5 (zero clearance) and epsilon = 0.3 (a clearance);
  :func:`plot_instant_distributions`, ``figure_6_9.png``;
- figures 7 and 10: outer-raceway normal force of one followed ball over one rolling round (one
  cage revolution) against its angle, for several F_r and several epsilon;
  :func:`plot_rolling_rounds`, ``figure_7_10.png``;
- figures 8 and 11: bearing resistance against time for the same two sets;
  :func:`plot_resistance_signals`, ``figure_8_11.png``.

:func:`paper_figures` runs the simulations and writes the three files (``signatelec figures``
and ``pipelines/paper_figures.py``). Figures are built on :class:`matplotlib.figure.Figure` with
an Agg canvas (no pyplot state, no display) and written atomically: a temporary file in the
destination directory, then :func:`os.replace`.

Angles are the ball angle psi of the result tables: from the load direction -y,
counter-clockwise. Polar panels put psi = 0 at the bottom, as the bearing is drawn in the seed.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from signatelec.physics.quasistatic import clearance_for_epsilon
from signatelec.plots import new_figure, save_figure

#: Time after the set-up phases left for the spin-up transient to damp, s.
SETTLE_S = 2e-3
#: F_r of figures 7-8, as fractions of C_r (zero clearance, epsilon = 0.5).
LOAD_FRACTIONS = (0.1, 0.2, 0.3, 0.4)
#: F_r of figures 9-11, N (0.2 C_r of the seed's 6208).
EPSILON_SET_LOAD_N = 5820.0
#: Clearances of figures 10-11 besides the one giving epsilon = 0.3: preload, none, clearance, m.
EPSILON_SET_CLEARANCES_M = (-10e-6, 0.0, 20e-6)
#: Load parameter of figure 9.
FIGURE_9_EPSILON = 0.3
FIGURE_FILES = ("figure_6_9.png", "figure_7_10.png", "figure_8_11.png")

_CAGE_COLOUR = "tab:blue"
_BALL_COLOUR = "0.25"
_IDLE_COLOUR = "0.75"


# --- reading results -------------------------------------------------------------------------


def _wrap(angle_rad):
    """Angle in (-pi, pi]."""
    return np.angle(np.exp(1j * np.asarray(angle_rad, dtype=float)))


def steady_mean(result, column: str, settle_s: float = SETTLE_S) -> float:
    """Mean of a ``signals`` column over the steady phase, ``settle_s`` after the set-up."""
    steady = result.steady(settle_s=settle_s)
    if steady.empty:
        steady = result.steady()
    return float(steady[column].mean())


def instant_time_s(result, settle_s: float = SETTLE_S) -> float:
    """A steady instant with a ball nearest the load direction psi = 0 (the seed's picture)."""
    z = result.scene.bearing.n_balls
    steady = result.steady("balls", settle_s)
    if steady.empty:
        steady = result.steady("balls") if len(result.steady()) else result.balls
    angle = np.abs(_wrap(steady.angle_rad.to_numpy())).reshape(-1, z).min(axis=1)
    times = steady.time_s.to_numpy().reshape(-1, z)[:, 0]
    return float(times[int(np.argmin(angle))])


def instant_balls(result, time_s: float | None = None) -> pd.DataFrame:
    """Rows of ``result.balls`` at the recorded instant nearest ``time_s`` (default: see
    :func:`instant_time_s`), ordered by ball."""
    if time_s is None:
        time_s = instant_time_s(result)
    times = result.signals.time_s.to_numpy()
    nearest = times[int(np.argmin(np.abs(times - time_s)))]
    rows = result.balls[result.balls.time_s == nearest]
    return rows.sort_values("ball").reset_index(drop=True)


def cage_ball_angles_rad(ball_angle_rad) -> np.ndarray:
    """Angles of the cage balls, one between each ball k and ball k + 1 (mid-angle), rad.

    The result tables record the rolling balls only; the cage ball k starts at psi_k + pi / Z and
    stays between balls k and k + 1, so the mid-angle places it within a fraction of a degree.
    """
    psi = np.asarray(ball_angle_rad, dtype=float)
    gap = _wrap(np.roll(psi, -1, axis=-1) - psi)
    return _wrap(psi + 0.5 * gap)


@dataclass(frozen=True)
class RollingRound:
    """One followed ball over one rolling round (one cage revolution) of the steady phase."""

    ball: int
    time_s: np.ndarray
    angle_rad: np.ndarray  # in (-pi, pi], increasing for a positive inner-ring speed
    outer_force_n: np.ndarray
    inner_force_n: np.ndarray
    complete: bool  # False: the record is shorter than a round, the longest stretch is given


def rolling_round(result, settle_s: float = SETTLE_S) -> RollingRound:
    """The first ball to pass psi = +-pi after settling, followed until it passes it again.

    Starting and ending at the top of the bearing (psi = +-pi) gives a curve continuous over
    (-180, 180] degrees with the load zone in the middle, like the seed's figures 7 and 10. When
    the record holds no whole round (short runs), the ball with the longest stretch between two
    passages (or the ends of the record) is returned with ``complete=False``.
    """
    z = result.scene.bearing.n_balls
    steady = result.steady("balls", settle_s)
    if len(steady) < 2 * z:
        steady = result.steady("balls")
    if len(steady) < 2 * z:
        steady = result.balls
    angle = _wrap(steady.angle_rad.to_numpy()).reshape(-1, z)
    outer = steady.outer_force_n.to_numpy().reshape(-1, z)
    inner = steady.inner_force_n.to_numpy().reshape(-1, z)
    times = steady.time_s.to_numpy().reshape(-1, z)[:, 0]
    n = angle.shape[0]
    passages = np.abs(np.diff(angle, axis=0)) > math.pi  # (n - 1, z): a wrap between rows
    best = None
    for k in range(z):
        cuts = np.flatnonzero(passages[:, k]) + 1  # first row after each passage
        if cuts.size >= 2:
            start, stop, whole = int(cuts[0]), int(cuts[1]), True
        else:
            edges = np.concatenate(([0], cuts, [n]))
            i = int(np.argmax(np.diff(edges)))
            start, stop, whole = int(edges[i]), int(edges[i + 1]), False
        key = (whole, -start if whole else stop - start)
        if best is None or key > best[0]:
            best = (key, k, start, stop, whole)
    _, k, start, stop, whole = best
    rows = slice(start, stop)
    return RollingRound(
        ball=k,
        time_s=times[rows],
        angle_rad=angle[rows, k],
        outer_force_n=outer[rows, k],
        inner_force_n=inner[rows, k],
        complete=whole,
    )


# --- labels ----------------------------------------------------------------------------------


def load_label(result) -> str:
    fr = result.scene.operating.radial_load_n
    c_r = result.scene.bearing.dynamic_load_rating_n
    return f"$F_r$ = {fr / c_r:.1f} $C_r$ = {fr:.0f} N"


def clearance_label(result) -> str:
    c_um = round(result.scene.operating.clearance_m * 1e6, 1) + 0.0  # no "-0"
    eps = steady_mean(result, "epsilon")
    return rf"$\Delta_r$ = {c_um:g} µm, $\epsilon$ = {eps:.2f}"


def _two_sets(load_results: Sequence, epsilon_results: Sequence):
    """(results, legend label, panel title) of panels (a) several F_r and (b) several epsilon."""
    load_n = EPSILON_SET_LOAD_N
    if epsilon_results:
        load_n = epsilon_results[0].scene.operating.radial_load_n
    return (
        (load_results, load_label, r"(a) several $F_r$, $\Delta_r$ = 0 ($\epsilon$ = 0.5)"),
        (
            epsilon_results,
            clearance_label,
            rf"(b) several $\epsilon$, $F_r$ = {load_n:g} N ($\Delta_r$ < 0: preload)",
        ),
    )


# --- figures 6 and 9 -------------------------------------------------------------------------


def _polar_panel(ax, balls: pd.DataFrame, values, title: str, colour: str) -> None:
    psi = balls.angle_rad.to_numpy()
    values = np.nan_to_num(np.asarray(values, dtype=float), nan=0.0)
    conducting = balls.current_a.to_numpy() > 0.0 if "current_a" in balls else values > 0
    z = psi.size
    top = max(float(values.max()), 1e-300)
    rim = 1.12 * top
    ax.set_theta_zero_location("S")  # psi = 0 (load direction -y) at the bottom
    ax.set_theta_direction(1)  # counter-clockwise, as psi
    width = 0.45 * 2.0 * math.pi / z
    ax.bar(psi, values, width=width, color=np.where(conducting, colour, _IDLE_COLOUR), zorder=1)
    ax.scatter(psi, np.full(z, rim), s=60, color=_BALL_COLOUR, zorder=3, label="steel ball")
    ax.scatter(
        cage_ball_angles_rad(psi),
        np.full(z, rim),
        s=18,
        color=_CAGE_COLOUR,
        zorder=3,
        label="cage ball (insulating)",
    )
    ax.set_ylim(0.0, 1.2 * top)
    # thetagrids, not set_xticks: the latter would narrow the polar axes to the ticks' span
    ax.set_thetagrids(range(0, 360, 45), [f"{(d + 180) % 360 - 180}°" for d in range(0, 360, 45)])
    ticks = MaxNLocator(4).tick_values(0.0, top)
    ax.set_yticks(ticks[(ticks > 0.0) & (ticks <= 0.9 * top)])
    ax.set_rlabel_position(112.5)
    ax.tick_params(axis="y", labelsize=7)
    for label in ax.get_yticklabels():
        label.set_bbox({"facecolor": "white", "alpha": 0.8, "edgecolor": "none", "pad": 0.5})
        label.set_zorder(4)
    ax.set_axisbelow(False)  # grid and tick labels over the bars
    ax.tick_params(axis="x", labelsize=8)
    ax.set_title(title, fontsize=10)


def plot_instant_distributions(results: Sequence, time_s: Sequence[float] | None = None) -> Figure:
    """Seed figures 6 and 9: one row per result, columns (a) outer-raceway normal force,
    (b) current through each ball, (c) potential of each ball, at one steady instant.

    Bars are drawn at the ball angles; grey bars are balls carrying no current (touching one ring
    only), blue dots the insulating polyamide cage balls.
    """
    fig = new_figure(12.0, 4.3 * len(results))
    rows = fig.subfigures(len(results), 1, squeeze=False)[:, 0]
    for i, (result, row) in enumerate(zip(results, rows, strict=True)):
        if "current_a" not in result.balls:
            raise ValueError("plot_instant_distributions needs the electrical effect on")
        balls = instant_balls(result, None if time_s is None else time_s[i])
        t = float(balls.time_s.iloc[0])
        r_mohm = 1e3 * float(result.signals.resistance_ohm[result.signals.time_s == t].iloc[0])
        row.suptitle(
            f"{load_label(result)}, {clearance_label(result)}: t = {t * 1e3:.2f} ms, "
            f"R = {r_mohm:.3f} mOhm",
            fontsize=11,
        )
        axes = row.subplots(1, 3, subplot_kw={"projection": "polar"})
        _polar_panel(
            axes[0], balls, balls.outer_force_n, "(a) outer-raceway normal force, N", "tab:red"
        )
        _polar_panel(axes[1], balls, 1e3 * balls.current_a, "(b) ball current, mA", "tab:orange")
        _polar_panel(axes[2], balls, 1e3 * balls.potential_v, "(c) ball potential, mV", "tab:green")
        if i == 0:
            handles, _ = axes[2].get_legend_handles_labels()
            idle = Patch(color=_IDLE_COLOUR, label="ball carrying no current")
            axes[2].legend(
                handles=[*handles, idle],
                loc="upper right",
                bbox_to_anchor=(1.5, 1.14),
                fontsize=8,
            )
    return fig


# --- figures 7 and 10 ------------------------------------------------------------------------


def plot_rolling_rounds(load_results: Sequence, epsilon_results: Sequence) -> Figure:
    """Seed figures 7 and 10: outer-raceway normal force of one followed ball over one rolling
    round against its angle, (a) for several F_r at zero clearance, (b) for several epsilon."""
    fig = new_figure(12.0, 4.6)
    axes = fig.subplots(1, 2)
    for ax, (results, label, title) in zip(
        axes, _two_sets(load_results, epsilon_results), strict=True
    ):
        for result in results:
            rr = rolling_round(result)
            suffix = "" if rr.complete else " (partial round)"
            ax.plot(
                np.degrees(rr.angle_rad), rr.outer_force_n, lw=1.4, label=label(result) + suffix
            )
        ax.set_xlim(-180.0, 180.0)
        ax.set_xticks(np.arange(-180, 181, 45))
        ax.set_xlabel(r"ball angle $\psi$ from the load direction, deg")
        ax.set_ylabel("outer-raceway normal force $F_n$, N")
        ax.set_ylim(bottom=0.0)
        ax.grid(alpha=0.3)
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=8, loc="upper left")
    omega = (load_results or epsilon_results)[0].scene.operating.omega_rad_s
    fig.suptitle(
        f"One ball over one rolling round (cage revolution), omega = {omega:g} rad/s", fontsize=11
    )
    return fig


# --- figures 8 and 11 ------------------------------------------------------------------------


def plot_resistance_signals(load_results: Sequence, epsilon_results: Sequence) -> Figure:
    """Seed figures 8 and 11: bearing resistance against time, (a) several F_r at zero
    clearance, (b) several epsilon at F_r = 5820 N. The set-up phases are shaded; the vertical
    range is set by the steady phase (the first instants, with nearly unloaded balls, reach
    ohms and are clipped; an instant with no conducting ball, R = inf, leaves a gap)."""
    fig = new_figure(12.0, 4.6)
    axes = fig.subplots(1, 2)
    for ax, (results, label, title) in zip(
        axes, _two_sets(load_results, epsilon_results), strict=True
    ):
        low, top = math.inf, 0.0
        setup = 0.0
        for result in results:
            sig = result.signals
            r_mohm = 1e3 * sig.resistance_ohm.to_numpy()
            r_mohm = np.where(np.isfinite(r_mohm), r_mohm, np.nan)
            mean = 1e3 * steady_mean(result, "resistance_ohm")
            ax.plot(sig.time_s, r_mohm, lw=1.0, label=f"{label(result)}: mean {mean:.2f} mOhm")
            steady = r_mohm[sig.time_s.to_numpy() > result.scene.setup_time_s]
            if np.isfinite(steady).any():
                low = min(low, float(np.nanmin(steady)))
                top = max(top, float(np.nanmax(steady)))
            setup = max(setup, result.scene.setup_time_s)
        ax.axvspan(0.0, setup, color="0.9", zorder=0, label="set-up: clearance, load, spin-up")
        if top > 0.0:
            # frame the steady signals: their spread plus a margin, from 0 when that is near
            margin = 0.3 * (top - low) + 0.04 * top
            ax.set_ylim(max(low - margin, 0.0) if low - margin > 0.3 * top else 0.0, top + margin)
        ax.set_xlim(left=0.0)
        ax.set_xlabel("time, s")
        ax.set_ylabel("bearing resistance R, mOhm")
        ax.grid(alpha=0.3)
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=8, loc="best")
    omega = (load_results or epsilon_results)[0].scene.operating.omega_rad_s
    fig.suptitle(f"Electrical resistance of the bearing, omega = {omega:g} rad/s", fontsize=11)
    return fig


# --- the paper's figures end to end ----------------------------------------------------------


@dataclass(frozen=True)
class PaperCases:
    """Scenes of the seed's figures: ``loads`` (figs 7-8), ``epsilons`` (figs 10-11) and the
    two scenes of figures 6 and 9, which belong to those sets."""

    loads: tuple
    epsilons: tuple
    figure_6: object
    figure_9: object

    def unique(self) -> list:
        seen: dict = {}
        for scene in (*self.loads, *self.epsilons):
            seen.setdefault(scene, None)
        return list(seen)


def paper_cases(quick: bool = False, base=None) -> PaperCases:
    """The seed's section 4 scenes. Full runs last the set-up, ``SETTLE_S`` and one cage
    revolution plus one ball spacing (so a ball passes psi = pi and comes back); ``quick`` runs
    stop ``SETTLE_S`` after the set-up (a check of the pipeline, partial rolling rounds)."""
    from signatelec.config.scene import Scene

    base = base or Scene()
    # the paper's procedure: one spin-up (the base scene's) for every figure scene, whatever
    # its clearance would choose
    base = base.with_overrides(spin_up_time_s=base.procedure.spin_up_time_s)
    b = base.bearing
    omega = base.operating.omega_rad_s
    if quick:
        duration = base.setup_time_s + SETTLE_S
    else:
        period = 2.0 * math.pi / b.cage_speed_rad_s(omega)
        duration = base.setup_time_s + SETTLE_S + (1.0 + 1.0 / b.n_balls) * period + 1e-3
    duration = round(duration, 4)

    def scene(load_n: float, clearance_m: float):
        return replace(
            base,
            operating=replace(base.operating, radial_load_n=load_n, clearance_m=clearance_m),
            numerics=replace(base.numerics, duration_s=duration),
        )

    loads = tuple(scene(round(f * b.dynamic_load_rating_n, 6), 0.0) for f in LOAD_FRACTIONS)
    eps_clearance = clearance_for_epsilon(b, EPSILON_SET_LOAD_N, omega, FIGURE_9_EPSILON)
    clearances = sorted((*EPSILON_SET_CLEARANCES_M, round(eps_clearance, 8)))
    epsilons = tuple(scene(EPSILON_SET_LOAD_N, c) for c in clearances)
    return PaperCases(
        loads=loads,
        epsilons=epsilons,
        figure_6=scene(EPSILON_SET_LOAD_N, 0.0),
        figure_9=scene(EPSILON_SET_LOAD_N, round(eps_clearance, 8)),
    )


def paper_figures(
    out_dir: str | Path, *, quick: bool = False, progress: bool = True, base=None
) -> list[Path]:
    """Simulate the seed's section 4 scenes and write ``FIGURE_FILES`` into ``out_dir``.

    - ``figure_6_9.png``: force, current and potential around the bearing at epsilon 0.5 and 0.3;
    - ``figure_7_10.png``: a followed ball's outer-raceway force over one rolling round;
    - ``figure_8_11.png``: bearing resistance against time.

    Raises :class:`signatelec.config.scene.SceneError` for a refused scene and
    :class:`signatelec.engines.dem.run.DivergenceError` for a run that diverges.
    """
    from tqdm import tqdm

    from signatelec.engines.simulate import simulate
    from signatelec.physics.electrical import CurrentDensityWarning

    cases = paper_cases(quick=quick, base=base)
    results = {}
    scenes = cases.unique()
    with warnings.catch_warnings():
        # The first recorded instants, with nearly unloaded balls, exceed the seed's 0.1 A/mm^2
        # density at 0.1 A; that warning is about harm to a real bearing, not about the figures.
        warnings.simplefilter("ignore", CurrentDensityWarning)
        for scene in tqdm(scenes, desc="paper figures", unit="run", disable=not progress):
            results[scene] = simulate(scene)
    out = Path(out_dir)
    loads = [results[s] for s in cases.loads]
    epsilons = [results[s] for s in cases.epsilons]
    figures = (
        plot_instant_distributions([results[cases.figure_6], results[cases.figure_9]]),
        plot_rolling_rounds(loads, epsilons),
        plot_resistance_signals(loads, epsilons),
    )
    return [save_figure(fig, out / name) for fig, name in zip(figures, FIGURE_FILES, strict=True)]
