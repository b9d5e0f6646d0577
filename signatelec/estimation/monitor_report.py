"""The output of ``signatelec monitor``: the window table, the summary and the picture.

:func:`write_monitor` writes, through the output-directory contract of :mod:`signatelec.io`
(a temporary directory exchanged with ``DIR`` in one rename, the marker, nothing half-written):

- ``windows.parquet``: one row per window (times, speed, resistance envelope, the estimate of
  ``signatelec estimate`` with intervals and class probabilities, in-domain score, ``status``;
  the bearing's ``condition`` with its probabilities and spall length on the assessed windows);
- ``summary.json``: the trace, the settings, ``stretches`` (``start_s``, ``end_s``,
  ``radial_load_n`` with ``_low`` and ``_high``, ``epsilon``, ``clearance_m``, ``regime``,
  ``regime_probability``, ``condition``, ``condition_probability``, ``condition_confident``,
  ...), ``changes`` (``time_s``, ``what``, ``probability``) and ``alarms`` (``time_s``,
  ``kind``: load, regime or condition, ``what``, ``probability``, ``change``: the index of the
  change that raised it);
- ``monitor.png``: resistance envelope, F_r with its band (windows and stretches), regime
  probabilities and the share of the condition's assessments called faulty, alarms against time.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec._version import __version__
from signatelec.config.bearing import same_bearing
from signatelec.config.constraints import HEALTHY
from signatelec.estimation.evidence import bias_ratios
from signatelec.measurement.traces import daylight_saving, time_text

FILES = ("windows.parquet", "summary.json", "monitor.png")
COMMAND = "monitor"


#: How the warning of a stretch confidently called faulty begins.
FAULTY_WARNING = "condition "


def _clean(value):
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _long_window(window_s: float | None) -> str | None:
    """The warning for windows longer than the training windows, or None."""
    from signatelec.estimation.features import LENGTH_DEPENDENT
    from signatelec.estimation.monitor_settings import WINDOW_S

    if window_s is None or window_s <= WINDOW_S * (1.0 + 1e-9):
        return None
    return (
        f"--window {window_s:g} s is longer than the training windows (at most {WINDOW_S:g} s): "
        f"the features that grow with the length ({', '.join(LENGTH_DEPENDENT)}) are outside "
        "what the model saw, the answer is an extrapolation"
    )


def qualify(
    stretches: list[dict],
    ranges: dict | None = None,
    window_s: float | None = None,
    faulty_ranges: dict | None = None,
    condition_model=None,
) -> list:
    """Mark, in place, each stretch whose windows cannot carry a confident answer: its
    ``warnings`` (what ``estimate`` warns of for one trace, read from the windows that answered
    the stretch, :func:`~signatelec.estimation.evidence.combine_stretch`'s ``no_line_share``,
    ``omega_rad_s`` and ``in_domain_score``, and the ``stretch_in_domain_score`` of their mean
    features where the stretch model answered: no ball-pass line in most of them, so the speed is
    unchecked and no regime call is confident (the screen's verdict, not the window's harmonic
    SNR: held-out DEM states whose ripple lies below 0.2 % noise give SNR 2-7, as white noise
    does, and were read right; an SNR rule flagged 32 of 140 acceptance stretches, all right);
    a speed outside the training range of the load-state model that answered (``ranges``, or
    ``faulty_ranges`` for a stretch the faulty model answered), an extrapolation; features (or
    a stretch's mean features) as atypical as the 1 % most atypical training traces (or
    stretches) of that model; windows longer than the
    training windows, a condition confidently not healthy (the load-state models learnt
    healthy bearings), ``window_s`` above :data:`~signatelec.estimation.monitor_settings.WINDOW_S`,
    whose length-dependent features (:data:`~signatelec.estimation.features.LENGTH_DEPENDENT`)
    the model never saw) and ``regime_confident`` (the regime probability at least
    :data:`~signatelec.estimation.estimate.CONFIDENT_PROBABILITY` and no warning). A
    condition called at a speed outside the ``condition_model``'s training range is warned of
    apart, in ``condition_warnings`` (:func:`~signatelec.estimation.diagnose.speed_warning`:
    a healthy call there is not confident), which leaves the load state's confidence alone;
    ``condition_confident`` as ``estimate``'s (the call's probability, on the condition model's
    training mix, at least :data:`~signatelec.estimation.diagnose.CONFIDENT_CONDITION`, and not
    a healthy call so warned).
    Returns the warnings as notes naming their stretch (the window's length: one note for
    all)."""
    from signatelec.estimation.diagnose import CONFIDENT_CONDITION, speed_warning
    from signatelec.estimation.domain import WARN_SCORE, outside_speeds
    from signatelec.estimation.estimate import CONFIDENT_PROBABILITY

    long_window = _long_window(window_s)
    notes = [long_window] if long_window and stretches else []
    for s in stretches:
        warnings = []
        if (s.get("no_line_share") or 0.0) >= 0.5:
            warnings.append(
                "no ball-pass line at the given speed in most of its windows (the ripple "
                "screen's): the speed is unchecked or wrong and no regime call is confident "
                "(a trace without ripple, a wrong speed, or a state whose ripple lies below "
                "the noise)"
            )
        healthy_model = s.get("load_model") != "faulty"
        omega = s.get("omega_rad_s")
        answered = ranges if healthy_model else faulty_ranges
        if (speeds := outside_speeds(answered, omega)) is not None:
            lo, hi = speeds
            warnings.append(
                f"omega {omega:g} rad/s is outside the training range {lo:g}-{hi:g} "
                "rad/s: extrapolating, the interval does not cover the model's error there"
            )
        score = s.get("in_domain_score")
        if score is not None and score < WARN_SCORE:
            warnings.append(
                f"median in-domain score {score:.2g} (below {WARN_SCORE:g}): the windows are "
                "unlike the training traces, the answer is an extrapolation"
            )
        score = s.get("stretch_in_domain_score")
        if score is not None and score < WARN_SCORE:
            warnings.append(
                f"in-domain score {score:.2g} of the stretch's mean features (below "
                f"{WARN_SCORE:g}): unlike the stretch model's training stretches, the answer is "
                "an extrapolation"
            )
        condition = s.get("condition")
        if "radial_load_n" in s and condition not in (None, HEALTHY) and healthy_model:
            if (s.get("condition_probability") or 0.0) >= CONFIDENT_CONDITION:
                warnings.append(
                    f"{FAULTY_WARNING}{condition}: answered by the load-state model of healthy "
                    "bearings (no faulty model, or no window in its domain), the load state is "
                    "an extrapolation"
                )
        if condition is not None and condition_model is not None:
            off = speed_warning(condition_model, s.get("condition_speeds_rad_s"), condition)
            s["condition_warnings"] = [f"condition: {off}"] if off else []
        if s.get("condition_refused"):
            s.setdefault("condition_warnings", []).append(_refused(s))
        if condition is not None:  # as estimate's: the call's probability, a healthy call's speed
            sure = (s.get("condition_probability") or 0.0) >= CONFIDENT_CONDITION
            s["condition_confident"] = bool(
                sure and not (condition == HEALTHY and s.get("condition_warnings"))
            )
        notes += [
            f"stretch {time_text(s['start_s'])}-{time_text(s['end_s'])} s: {w}"
            for w in warnings + s.get("condition_warnings", []) + _joined(s)
        ]
        if long_window:
            warnings.append(long_window)
        s["warnings"] = warnings
        s["regime_confident"] = bool(
            not warnings and (s.get("regime_probability") or 0.0) >= CONFIDENT_PROBABILITY
        )
    return notes


def _refused(stretch: dict) -> str:
    """The warning of a stretch some of whose condition assessments were refused as unlike
    every training trace of the condition model (:func:`~signatelec.estimation.health.
    refused_assessments`): the stretch holds what the model did not learn, so a healthy call
    there is not confident."""
    n, done = stretch["condition_refused"], stretch.get("condition_assessments", 0)
    return (
        f"condition: {n} of its {n + done} assessments (the first at "
        f"{time_text(stretch['condition_refused_first_s'])} s) were unlike every training "
        "trace of the condition model, a fault or a bearing it did not learn, and were not "
        "assessed; a healthy call is not confident"
    )


def _joined(stretch: dict) -> list[str]:
    """A note on the changes of a stretch's features that came with its speed and were joined
    (:func:`~signatelec.estimation.evidence.stretches_and_changes`), or none."""
    times = stretch.get("joined_s")
    if not times:
        return []
    low, high = stretch.get("omega_range_rad_s") or (math.nan, math.nan)
    return [
        f"one load state over {low:.6g}-{high:.6g} rad/s: its features changed with the speed "
        f"at {len(times)} time{'s' if len(times) > 1 else ''} (the first at "
        f"{time_text(times[0])} s), none beyond the alarm thresholds"
    ]


def qualify_alarms(alarms: list[dict], stretches: list[dict]) -> None:
    """Mark, in place, each alarm ``confident`` when neither stretch it joins carries a warning
    (:func:`qualify`): a regime alarm into a stretch without a ball-pass line is no finding.
    The warning that a faulty stretch's load state is an extrapolation does not touch the
    condition alarm that found the fault; a condition alarm into a healthy call at a speed
    outside the condition model's training range (``condition_warnings``) is not confident;
    a load or regime alarm between a stretch answered by the healthy load model and one
    answered by the faulty model is not confident (the two models' errors differ)."""
    for a in alarms:
        near = [
            s
            for s in stretches
            if abs(s["start_s"] - a["time_s"]) < 1e-9 or abs(s["end_s"] - a["time_s"]) < 1e-9
        ]
        warned = [w for s in near for w in s.get("warnings", ())]
        if a["kind"] == "condition":
            warned = [w for w in warned if not w.startswith(FAULTY_WARNING)]
            # a fault gone, into a healthy call where it is not confident (the speed)
            warned += [
                w
                for s in near
                if abs(s["start_s"] - a["time_s"]) < 1e-9 and s.get("condition") == HEALTHY
                for w in s.get("condition_warnings", ())
            ]
        elif len({s.get("load_model", "healthy") for s in near}) > 1:
            # two load-state models answered the two sides: their difference is not a change
            warned.append("answered by different load-state models")
        a["confident"] = not warned


class LiveAlarms:
    """The alarms of a record still being read (a followed file, standard input), on the way:
    ``summarise(table)`` gives the summary of the windows answered so far (the output's own,
    :func:`summary_of`), read again whenever windows were answered (every 100 when following:
    20 s of record at a 0.2 s hop), but in no more than a tenth of the wall time (it reads
    every window so far again). Each alarm is told once, marked provisional: the summary
    written at the end, from the whole record, is the answer (a change found near the end of
    what was read may move, or go, as windows arrive: one told that a later reading no longer
    shows is told withdrawn). An alarm of the same kind within 1.5 hops (``hop_s``) of one
    told is that one."""

    def __init__(self, summarise, hop_s: float):
        self.summarise, self.hop_s = summarise, hop_s
        self.told: list[tuple[str, float]] = []
        self.next_s, self.windows = -math.inf, 0

    def __call__(self, table) -> list[str]:
        """Lines of the alarms not told before."""
        import time

        start = time.monotonic()
        if start < self.next_s or table.n_windows == self.windows:
            return []
        self.windows = table.n_windows
        alarms = self.summarise(table)["alarms"]
        self.next_s = start + 10.0 * (time.monotonic() - start)
        now = [(a["kind"], a["time_s"]) for a in alarms]
        lines = []
        for kind, t in list(self.told):  # told, and gone from the summary so far
            if not self._among(kind, t, now):
                self.told.remove((kind, t))
                lines.append(
                    f"alarm at {time_text(t)} s ({kind}) withdrawn: the record read since no "
                    "longer shows it"
                )
        for a in alarms:
            kind, t = a["kind"], a["time_s"]
            if self._among(kind, t, self.told):
                continue
            self.told.append((kind, t))
            sure = "" if a.get("confident", True) else "; not confident"
            lines.append(
                f"alarm at {time_text(t)} s (provisional): {a['what']} (probability "
                f"{a['probability']:.3f}{sure})"
            )
        return lines

    def _among(self, kind: str, time_s: float, alarms: list[tuple[str, float]]) -> bool:
        """Whether an alarm of ``kind`` at ``time_s`` is one of ``alarms`` (within 1.5 hops)."""
        return any(k == kind and abs(t - time_s) <= 1.5 * self.hop_s for k, t in alarms)


def summary_of(table, settings, stretches, changes, alarms, extra: dict, model=None) -> dict:
    """The content of ``summary.json``; ``model``: the load-state model, whose training ranges
    (and its faulty model's) the stretches are qualified against (:func:`qualify`)."""
    windows = table.frame()
    settings = settings if model is None else settings.for_model(model)  # (its bearing)
    condition = getattr(model, "condition", None)
    model = model if settings.load_state else None  # (another bearing's: no load state)
    faulty = getattr(model, "faulty", None)
    notes = list(table.notes) + qualify(
        stretches,
        model.info.get("ranges") if model is not None else None,
        settings.window_s if settings.load_state else None,
        faulty.info.get("ranges") if faulty is not None else None,
        condition,
    )
    if stretches and any("radial_load_n" in x for x in stretches) and bias_ratios(model):
        notes.append(
            "the stretches' intervals take the whole of their model part (ratio 1: as wide as "
            "a window's own, where the windows answer): the error this model makes on a state, "
            "which its windows share, was not calibrated (`signatelec study monitor` "
            "calibrates the default model's)"
        )
    if table.time_origin_utc is not None:
        notes.append(
            f"times are seconds after the record's first timestamp, {table.time_origin_utc} "
            "(time_origin_utc)"
        )
    if table.gaps:
        longest = max(table.gaps, key=lambda g: g[1] - g[0])
        notes.append(
            f"{len(table.gaps)} gap{'s' if len(table.gaps) > 1 else ''} in the record (no "
            "sample for longer than a quarter of a ball pass), "
            f"{sum(b - a for a, b in table.gaps):.6g} s in all, the longest from t = "
            f"{time_text(longest[0])} to {time_text(longest[1])} s"
            f"{daylight_saving(longest[1] - longest[0])}: the windows there carry no "
            "estimate ('no data'), a change found across a gap is timed at its end ('gap_s'), "
            "and a stretch over one was not observed there ('unobserved_s')"
        )
    if not settings.load_state:  # the condition alone: what it did not see is said
        notes.append(settings.window_status.replace("no load state", "load state not estimated"))
        notes += _unassessed_tail(windows, settings)
    qualify_alarms(alarms, stretches)
    status = windows["status"] if "status" in windows else pd.Series(dtype=str)
    refused = status[status != "ok"]
    # a gap is told in gaps, another bearing's missing load state in the notes
    told = refused[~refused.str.startswith(("no data", "no load state"))]
    return _clean(
        {
            "signatelec": __version__,
            "trace": {
                "sample_rate_hz": table.sample_rate_hz,
                "n_samples": table.n_samples,
                "duration_s": table.duration_s,
                "windows": int(len(windows)),
                "windows_without_estimate": int(refused.size),
                "first_refusal": str((told if told.size else refused).iloc[0])
                if refused.size
                else None,
                "interrupted": table.interrupted,
                "time_origin_utc": table.time_origin_utc,
            },
            "settings": {
                "window_s": settings.window_s,
                "hop_s": settings.hop,
                "omega_rad_s": settings.omega_rad_s,
                "speed_column": settings.speed_column,
                "track_speed": settings.track_speed,
                # the bearing read (None: the seed's), and whether the model learnt its load
                "bearing": None if same_bearing(settings.bearing, None) else settings.bearing.name,
                "load_state": settings.load_state,
                **extra,
            },
            "notes": notes,
            "gaps": [{"start_s": a, "end_s": b} for a, b in table.gaps],
            "analysis_cpu_s": table.cpu_s,
            "stretches": stretches,
            "changes": changes,
            "alarms": alarms,
        }
    )


def _unassessed_tail(windows: pd.DataFrame, settings) -> list[str]:
    """A note on the record's end that no assessment of the condition saw (longer than a hop:
    the condition is assessed every ``condition_every_s``), or none."""
    if "condition" not in windows or not windows["condition"].notna().any():
        return []
    last = float(windows.loc[windows["condition"].notna(), "end_s"].max())
    tail = float(windows["end_s"].max()) - last
    if tail <= settings.hop * (1.0 + 1e-9):
        return []
    return [
        f"the condition is assessed every {settings.condition_every_s:g} s (--condition-every): "
        f"the last assessment ends at t = {time_text(last)} s, {tail:.6g} s before the last "
        "window's end, and what the record shows after it is not assessed"
    ]


def _legend(ax) -> None:
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8)


def _steps(stretches: list[dict], key: str) -> tuple[list, list]:
    """x, y of each stretch's value of ``key`` as a flat segment, segments split by NaN."""
    xs, ys = [], []
    for s in stretches:
        xs += [s["start_s"], s["end_s"], np.nan]
        q = s.get(key)
        q = np.nan if q is None else q
        ys += [q, q, np.nan]
    return xs, ys


def _broken(frame: pd.DataFrame, gaps: list[tuple]) -> pd.DataFrame:
    """``frame`` with a row of NaN in each of the ``gaps``, in time order: its lines break there."""
    if gaps and "time_s" in frame:
        middle = pd.DataFrame({"time_s": [0.5 * (a + b) for a, b in gaps]})
        frame = pd.concat([frame, middle], ignore_index=True).sort_values("time_s")
    return frame


def _rows_with(windows: pd.DataFrame, column: str) -> pd.DataFrame:
    """The windows that hold a value of ``column`` (none when it is not there)."""
    return windows[windows[column].notna()] if column in windows else windows.iloc[0:0]


def draw(windows: pd.DataFrame, summary: dict, path: Path) -> None:
    from matplotlib.collections import PolyCollection

    from signatelec.plots import new_figure, save_figure

    fig = new_figure(9.0, 8.0)
    axes = fig.subplots(3, 1, sharex=True)
    gaps = [(g["start_s"], g["end_s"]) for g in summary.get("gaps", ())]
    ok = _broken(windows[windows["status"] == "ok"] if "status" in windows else windows, gaps)
    t = ok["time_s"].to_numpy() if "time_s" in ok else np.empty(0)
    ax = axes[0]
    # every window measured, whatever became of its estimate (another bearing's have none)
    seen, mean = (
        _broken(_rows_with(windows, c), gaps) for c in ("resistance_min_ohm", "level_mean_ohm")
    )
    if len(seen):
        ax.fill_between(
            seen["time_s"],
            seen["resistance_min_ohm"] * 1e3,
            seen["resistance_max_ohm"] * 1e3,
            color="0.8",
            label="window min-max",
        )
    if len(mean):  # (another bearing's: the assessed windows' alone, marked)
        style = "k-" if 2 * len(mean) > len(seen) else "k.-"
        ax.plot(mean["time_s"], mean["level_mean_ohm"] * 1e3, style, lw=0.8, label="window mean")
    ax.set_ylabel("resistance (mOhm)")
    _legend(ax)
    ax = axes[1]
    status = windows["status"] if "status" in windows else pd.Series(dtype=str)
    if status.str.startswith("no load state").any():
        ax.text(
            0.5, 0.5, "load state not estimated: the load-state model learnt another bearing",
            ha="center", fontsize=8, transform=ax.transAxes,
        )  # fmt: skip
        ax.set_yticks([])
    if t.size and "radial_load_n" in ok:
        ax.fill_between(
            t,
            ok["radial_load_n_low"],
            ok["radial_load_n_high"],
            color="C0",
            alpha=0.2,
            lw=0,
            label="window 90 % interval",
        )
        ax.plot(t, ok["radial_load_n"], ".", color="C0", ms=2, label="window estimate")
    # the stretches' bands as one collection and their estimates as one line broken by NaN
    # (an artist per stretch cost ~1 ms each to build and draw: 120 stretches in an hour)
    stretches = [s for s in summary["stretches"] if "radial_load_n" in s]
    if stretches:
        ax.add_collection(
            PolyCollection(
                [
                    [
                        (s["start_s"], s["radial_load_n_low"]),
                        (s["start_s"], s["radial_load_n_high"]),
                        (s["end_s"], s["radial_load_n_high"]),
                        (s["end_s"], s["radial_load_n_low"]),
                    ]
                    for s in stretches
                ],
                facecolors="C3",
                alpha=0.35,
                lw=0,
                label="stretch 90 % interval",
            )
        )
        ax.autoscale_view()
        ax.plot(*_steps(stretches, "radial_load_n"), "C3-", lw=1.5)
    ax.set_ylabel("F_r (N)")
    _legend(ax)
    ax = axes[2]
    # the regime's probabilities, or without a load state the condition's assessments'
    what = "regime" if any(c.startswith("regime_probability_") for c in ok) else "condition"
    shown = ok if what == "regime" else _rows_with(windows, "condition")
    probs = [c for c in shown.columns if c.startswith(f"{what}_probability_")]
    for j, c in enumerate(probs):
        ax.plot(
            shown["time_s"],
            shown[c],
            ".",
            ms=2 if what == "regime" else 5,
            color=f"C{j}",
            alpha=0.5,
        )
        ax.plot(
            *_steps(summary["stretches"], c),
            "-",
            color=f"C{j}",
            lw=2,
            label=c.removeprefix(f"{what}_probability_"),
        )
    if any("condition_faulty_share" in s for s in summary["stretches"]):
        ax.plot(
            *_steps(summary["stretches"], "condition_faulty_share"),
            "k--",
            lw=1.2,
            label="assessments called faulty",
        )
    ax.set_ylim(-0.02, 1.02)
    ax.set_ylabel(f"{what} probability")
    ax.set_xlabel("time (s)")
    _legend(ax)
    for a in axes if gaps else ():  # the gaps shaded, one collection per axis
        spans = [[(lo, 0), (lo, 1), (hi, 1), (hi, 0)] for lo, hi in gaps]
        a.add_collection(
            PolyCollection(spans, facecolors="0.9", lw=0, transform=a.get_xaxis_transform())
        )
    if gaps:
        axes[0].plot([], [], color="0.9", lw=6, label="no data")
        _legend(axes[0])
    # the alarms as one collection of vertical lines per axis and colour (axvline's spans)
    load = [alarm["time_s"] for alarm in summary["alarms"] if alarm["kind"] == "load"]
    other = [alarm["time_s"] for alarm in summary["alarms"] if alarm["kind"] != "load"]
    for colour, times in (("C3", load), ("C4", other)):
        if times:
            for a in axes:
                a.vlines(
                    times,
                    0,
                    1,
                    transform=a.get_xaxis_transform(),
                    colors=colour,
                    lw=0.8,
                    linestyles="--",
                )
    one = {"stretches": "stretch", "changes": "change", "alarms": "alarm"}
    counts = [f"{len(summary[k])} {one[k] if len(summary[k]) == 1 else k}" for k in one]
    axes[0].set_title(
        f"{', '.join(counts)} (dashed: red load, purple regime/condition)", fontsize=9
    )
    save_figure(fig, path)


def write_monitor(out, windows: pd.DataFrame, summary: dict) -> None:
    """Replace ``out`` with the monitor's output (module docstring)."""
    import pyarrow.parquet as pq

    from signatelec.io import replace_directory, table_with_metadata

    with replace_directory(out, COMMAND) as tmp:
        pq.write_table(
            table_with_metadata(windows, {"monitor": summary["settings"]}), tmp / "windows.parquet"
        )
        (tmp / "summary.json").write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n")
        draw(windows, summary, tmp / "monitor.png")


def format_summary(summary: dict) -> str:
    tr = summary["trace"]
    lines = [
        f"trace: {tr['n_samples']} samples at {tr['sample_rate_hz']:.6g} Hz "
        f"({tr['duration_s']:.4g} s), {tr['windows']} windows "
        f"({tr['windows_without_estimate']} without an estimate)"
    ]
    if tr["first_refusal"]:
        lines.append(f"  first window without an estimate: {tr['first_refusal']}")
    lines += [f"note: {n}" for n in summary["notes"]]
    lines.append(f"{len(summary['stretches'])} stretches (90 % intervals):")
    for s in summary["stretches"]:
        line = f"  {s['start_s']:9.3f}-{s['end_s']:9.3f} s  "
        if "radial_load_n" in s:
            line += (
                f"F_r {s['radial_load_n']:.0f} N [{s['radial_load_n_low']:.0f}, "
                f"{s['radial_load_n_high']:.0f}]  epsilon {s['epsilon']:.3f}  clearance "
                f"{s['clearance_m'] * 1e6:+.1f} um  {s['regime']} ({s['regime_probability']:.2f})"
                + ("" if s.get("regime_confident", True) else ", not confident")
            )
        elif not summary["settings"].get("load_state", True):  # a bearing the model did not learn
            line += "load state not estimated"
        else:
            line += "no load estimate (no window of it carries one)"
        if "condition" in s:
            line += f"  condition {s['condition']} ({s['condition_probability']:.2f})"
            line += ", extrapolated" if s.get("condition_warnings") else ""
            # (under a stated prior the probability shown is the prior's, the call's confidence
            # the training mix's)
            prior = summary["settings"].get("healthy_prior") is not None
            unsure = ", uncertain" + (" on the training mix" if prior else "")
            line += "" if s.get("condition_confident", True) else unsure
        lines.append(line)
    for a in summary["alarms"]:
        lines.append(
            f"alarm at {a['time_s']:.3f} s: {a['what']} (probability {a['probability']:.3f})"
            + ("" if a.get("confident", True) else "; not confident: see the notes")
        )
    return "\n".join(lines)
