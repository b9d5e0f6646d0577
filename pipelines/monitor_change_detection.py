"""The monitor's change detection on the design bank of the monitoring study.

Usage::

    python pipelines/monitor_change_detection.py [--bank DIR] [--out DIR] [--minutes M]

The design states of ``signatelec study monitor`` (``--bank``, default
``/tmp/monitor-bank/design``, read as cached or run; not the acceptance records) are
monitored in two ways, as ``signatelec monitor`` does (0.2 s windows, the default model):

1. *records*: the study's design records (``DESIGN_SEED + 1``: 6 stretches of 2-10 s,
   consecutive states a load step of 10-50 % or a regime apart); each true change should be
   found within one window, and nothing else;
2. *constant records*: each state tiled for ``--minutes`` (default 10) with fresh 0.2 % noise;
   every change found there is false. The detector is asked at false-alarm rates of 0.1 to
   100 per hour, and the count compared with the nominal rate x duration (with the 95 %
   Poisson upper bound of the count); per series of the detector, the windows' lag-1
   autocorrelation, the variance of means of 5 and of 50 windows against that of
   independent windows (the DEM's tile of 0.25 s repeats every 5 windows of 0.2 s), and the
   spread of the scatter over the states (the detector's noise model).

The window tables are cached in ``--out`` (default ``out/monitor_change_detection``); the
report goes to ``--report`` (default ``docs/monitor/change_detection.md``). About 5 min of
CPU on first run.
"""

from __future__ import annotations

import argparse
import pickle
import time
from pathlib import Path

import numpy as np
import pandas as pd

RATES = (0.1, 1.0, 10.0, 100.0)
SERIES = ("log level", "log F_r", "epsilon", "h1_rel", "h2_rel")


def window_tables(bank, out: Path, minutes: float):
    """(records, constant records): [(truth, windows)] each, cached in ``out``."""
    from threadpoolctl import threadpool_limits

    from signatelec.estimation.monitor import MonitorSettings, monitor_trace
    from signatelec.estimation.persistence import default_model
    from signatelec.studies.monitor import N_CALIBRATION_RECORDS, N_STRETCHES
    from signatelec.studies.monitor_records import (
        DESIGN_SEED,
        OMEGA_RAD_S,
        SAMPLE_RATE_HZ,
        assemble_record,
        write_record,
    )

    cache = out / f"windows-{minutes:g}min.pkl"
    if cache.is_file():
        return pickle.loads(cache.read_bytes())
    model = default_model()
    settings = MonitorSettings(omega_rad_s=OMEGA_RAD_S)
    path = out / "record.parquet"

    def monitored(noisy):
        write_record(path, noisy, SAMPLE_RATE_HZ)
        return monitor_trace(path, model, settings).frame()

    records, constant = [], []
    with threadpool_limits(1):
        rng = np.random.default_rng(DESIGN_SEED + 1)  # as the study's design records
        for _ in range(N_CALIBRATION_RECORDS):
            noisy, truth = assemble_record(bank, rng, N_STRETCHES, None)
            records.append((truth, monitored(noisy)))
        rng = np.random.default_rng(DESIGN_SEED + 7)
        for state in bank.state:
            one = bank[bank.state == state].reset_index(drop=True)
            noisy, truth = assemble_record(one, rng, 0, minutes * 60.0)
            constant.append((truth, monitored(noisy)))
    path.unlink()
    cache.write_bytes(pickle.dumps((records, constant)))
    return records, constant


def record_table(records) -> pd.DataFrame:
    """Per true change: the error of the nearest reported change; spurious changes."""
    from signatelec.estimation.evidence import stretches_and_changes
    from signatelec.studies.monitor_metrics import match_record

    rows = []
    for i, (truth, windows) in enumerate(records):
        stretches, changes, _ = stretches_and_changes(windows, 0.2)
        _, chg = match_record(truth, stretches, changes, windows, 0.2)
        chg.insert(0, "record", i)
        rows.append(chg)
    return pd.concat(rows, ignore_index=True)


def poisson_upper(k: int, level: float = 0.95) -> float:
    """Upper bound of a Poisson mean given k counts (Garwood 1936)."""
    from scipy import stats

    return float(stats.chi2.ppf(level, 2 * (k + 1)) / 2.0)


def constant_tables(constant) -> tuple[pd.DataFrame, pd.DataFrame, float]:
    """(false changes per nominal rate, per-series statistics per state, hours)."""
    from signatelec.estimation.changes import change_points, detector_series
    from signatelec.estimation.evidence import stretches_and_changes, usable

    counts = dict.fromkeys(RATES, 0)
    reported = 0
    hours = 0.0
    stats_rows = []
    for truth, windows in constant:
        good = usable(windows)
        hours += len(good) * 0.2 / 3600.0
        for rate in RATES:
            counts[rate] += len(change_points(good, 0.2, rate))
        reported += len(stretches_and_changes(windows, 0.2)[1])
        x = detector_series(good)
        n = x.shape[0]
        for j, name in enumerate(SERIES):
            e = x[:, j] - x[:, j].mean()
            row = {"state": int(truth.state.iloc[0]), "regime": truth.regime.iloc[0]}
            row.update(series=name, sd=float(e.std()), r1=float(e[:-1] @ e[1:] / (e @ e)))
            for b in (5, 50):
                m = e[: n // b * b].reshape(-1, b).mean(axis=1)
                row[f"vr{b}"] = float(m.var() * b / e.var())
            stats_rows.append(row)
    rate_rows = [
        {
            "nominal_per_hour": r,
            "expected": r * hours,
            "found": counts[r],
            "found_per_hour": counts[r] / hours,
            "upper95_per_hour": poisson_upper(counts[r]) / hours,
        }
        for r in RATES
    ]
    rates = pd.DataFrame(rate_rows)
    rates.attrs["reported"] = reported
    return rates, pd.DataFrame(stats_rows), hours


def white_noise_rates(hours: float = 10.0, seed: int = 1) -> pd.DataFrame:
    """False changes of independent Gaussian windows (5 series, two correlated), 10 min records,
    and of the same with stretches of 2-10 s whose F_r and epsilon scatter 16x apart."""
    from signatelec.estimation.changes import change_points

    rng = np.random.default_rng(seed)
    n = 3000
    rows = []
    for hetero in (False, True):
        counts = dict.fromkeys(RATES[1:], 0)
        for _ in range(int(round(hours * 3600 / (n * 0.2)))):
            x = rng.standard_normal((n, 5)) * 1e-3
            x[:, 1] += 0.8 * x[:, 0]
            if hetero:
                edges = np.r_[0, np.cumsum(rng.integers(10, 51, size=n // 10))]
                edges = np.r_[edges[edges < n], n]
                for i, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
                    x[a:b, 1:3] *= 4.0 if i % 2 else 0.25
            w = pd.DataFrame(
                {
                    "level_mean_ohm": 3e-3 * np.exp(x[:, 0]),
                    "radial_load_n": 5000.0 * np.exp(x[:, 1]),
                    "epsilon": 0.5 + x[:, 2],
                    "h1_rel": 1e-3 + x[:, 3],
                    "h2_rel": 1e-4 + x[:, 4],
                }
            )
            for r in counts:
                counts[r] += len(change_points(w, 0.2, r))
        for r, k in counts.items():
            rows.append(
                {
                    "windows": "scatter 16x apart by stretch" if hetero else "independent",
                    "nominal_per_hour": r,
                    "expected": r * hours,
                    "found": k,
                    "upper95_per_hour": poisson_upper(k) / hours,
                }
            )
    return pd.DataFrame(rows)


def report(changes, rates, series, hours, white, cpu_s) -> str:
    from signatelec.studies.monitor_metrics import _markdown_table

    true = changes[changes.kind == "true"]
    spurious = changes[changes.kind == "spurious"]
    err = true.error_s.abs()
    spread = series.groupby("series", sort=False).agg(
        sd_min=("sd", "min"),
        sd_median=("sd", "median"),
        sd_max=("sd", "max"),
        r1_median=("r1", "median"),
        r1_max_abs=("r1", lambda v: float(np.max(np.abs(v)))),
        vr5_median=("vr5", "median"),
        vr50_median=("vr50", "median"),
        vr50_max=("vr50", "max"),
    )
    return "\n".join(
        [
            "# Monitoring: change detection on the design bank",
            "",
            "Written by `pipelines/monitor_change_detection.py` on the design states of "
            "`signatelec study monitor` (drawn from `DESIGN_SEED`, not the acceptance "
            "records); windows of 0.2 s, the default model, false-alarm rate 0.1 per hour. "
            "The detector (`change_points` of `signatelec/estimation/changes.py`) was chosen "
            "on this evidence before the acceptance records were monitored with it; one rule "
            "came after that run (commit d063dce), prompted by a false change in the study's "
            "synthetic 60-min throughput record, not by the acceptance records: a second-pass "
            "segment of fewer than 21 windows takes the larger of its own local scatter and "
            "the record's (a 3-window segment's own had overstated its precision). The "
            "figures below are with it.",
            "",
            f"**Design records** ({changes.record.nunique()} records of 6 stretches): "
            f"{(err <= 0.2).sum()} of {len(true)} true changes found within one window "
            f"(median error {1e3 * err.median():.1f} ms, max {1e3 * err.max():.0f} ms); "
            f"{len(spurious)} spurious changes.",
            "",
            f"**Constant records** ({len(series.state.unique())} states x "
            f"{hours * 60 / len(series.state.unique()):.0f} min = {hours:.1f} h): changes "
            f"reported at 0.1 per hour: {rates.attrs['reported']}. The detector's changes "
            "against the nominal false-alarm rate (each candidate split tested at rate x hop "
            "/ 1 h: a Bonferroni bound, so at most the nominal rate), with the 95 % Poisson "
            "upper bound of the measured rate:",
            "",
            *_markdown_table(rates),
            "",
            "The same on synthetic windows (independent Gaussian, 10 h at each rate; and with "
            "the scatter of log F_r and epsilon 16x apart from stretch to stretch, as the "
            "model's outputs are between the DEM states below, at the same mean):",
            "",
            *_markdown_table(white),
            "",
            "**The windows' series**, per state of the constant records: the scatter (sd) "
            "over the states, the lag-1 autocorrelation, and the variance of means of 5 and "
            "50 windows over that of independent windows (1 when independent; the DEM tile "
            "of 0.25 s repeats every 5 windows):",
            "",
            *_markdown_table(spread.reset_index()),
            "",
            "The windows are independent (lag-1 autocorrelation within +-0.075; the variance "
            "ratios scatter about 1 as those of 60 blocks of 50 independent windows do, "
            "+-0.18), the tile's repetition included; but the model's outputs scatter 7x "
            "(log F_r) and 17x (epsilon) apart from one state to another, the log level and "
            "harmonics, set by the noise, within 1.3x (a harmonic below the noise is clipped "
            "at zero, and can sit there for 20 windows).",
            "",
            "**The former detector** (main 70ac036: one variance per series pooled over the "
            "record, change points merged away when neither F_r moved by the load threshold "
            "nor an estimated class changed), on the same window tables: 198 of 200 true "
            "changes within one window, 9 spurious changes. 8 of these lay within stretches "
            "of 3 states whose epsilon and F_r estimates scatter more than the record's "
            "pooled variance (epsilon of a preloaded state near the boundary jumping between "
            "0.41 and 0.52 window to window); not the windows' correlation. One true change "
            "(clearance at 3128 N to preload at 3170 N, epsilon 0.31 to 0.55) was found and "
            "merged away (F_r 1.3 % apart, both stretches estimated in the clearance regime); "
            "one (zero at 3315 N to preload at 3170 N) was found 1.76 s late, with a spurious "
            "change: it fell 0.24 s into a block's ripple screen, whose periodogram peak, "
            "moved by the two ripples' phase jump to 412.0 Hz against 409.7 Hz expected, "
            "refused the block's 2 s of windows. Three more were timed 0.197 s late: the "
            "straddling window was out of the model's domain and the change in its first "
            "2 %, which the level-mixing rule skipped for the next window's start. On the "
            "constant records it found 3 changes at 0.1 per hour (4, 7 and 28 at 1, 10 and "
            "100), all merged away.",
            "",
            f"CPU {cpu_s:.0f} s.",
            "",
        ]
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bank", default="/tmp/monitor-bank/design")
    parser.add_argument("--out", default="out/monitor_change_detection")
    parser.add_argument("--report", default="docs/monitor/change_detection.md")
    parser.add_argument("--minutes", type=float, default=10.0)
    args = parser.parse_args(argv)
    from signatelec.io import write_bytes_atomic
    from signatelec.studies.monitor_records import CALIBRATION_STATES, DESIGN_SEED, dem_bank

    clock = time.process_time()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    bank = dem_bank(args.bank, print, CALIBRATION_STATES, DESIGN_SEED)
    records, constant = window_tables(bank, out, args.minutes)
    changes = record_table(records)
    rates, series, hours = constant_tables(constant)
    white = white_noise_rates()
    text = report(changes, rates, series, hours, white, time.process_time() - clock)
    write_bytes_atomic(Path(args.report), text.encode())
    for name, frame in (("changes", changes), ("rates", rates), ("series", series)):
        frame.attrs = {}
        frame.to_parquet(out / f"{name}.parquet")
    print(text)


if __name__ == "__main__":
    main()
