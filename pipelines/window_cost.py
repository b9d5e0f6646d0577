"""What one window's analysis costs in CPU across the speeds the models cover, and why.

Usage::

    python pipelines/window_cost.py [--report DIR] [--label NAME] [--speeds N] [--passes N]
                                    [--redraw]

The monitor analyses each 0.2 s window of a 50 kHz trace (``analyse_windows``, a block of 10
windows at a time); its Welch segments span 4 ball passes, nper = round(4 fs / f_bp) samples,
so their length moves with the speed. Here: the quasi-static tier's steady resistance of the
seed bearing (F_r 5820 N, 8 um clearance) at ``--speeds`` speeds spread over the models' range
250-750 rad/s, sampled at 50 kHz with 0.2 % white noise, cut into 2 blocks of 10 windows of
0.2 s; process CPU time per window, the median of ``--passes`` passes over the blocks after one
pass unmeasured (compilation and first-use costs left out), with the BLAS library kept to one
thread as the monitor keeps it. Only the analysis is timed: the features, the models and the
reading come on top (docs/monitor, README "Throughput").

The rows are appended to ``window_cost.parquet`` in the report directory (default
``docs/monitor``) under ``--label`` (default: the checked-out commit), replacing that label's
earlier rows, so running it on two versions of the code (``PYTHONPATH=<other checkout>``) draws
both in ``window_cost.png``; ``window_cost.md`` tabulates them. ``--redraw``: the figure and
the table of the stored rows, nothing measured.
"""

from __future__ import annotations

import argparse
import subprocess
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from monitor_bias import markdown

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_RATE_HZ = 50000.0
WINDOW_S = 0.2
BLOCKS = 2
BLOCK_WINDOWS = 10
NOISE_FRACTION = 0.002


def largest_prime_factor(n: int) -> int:
    factor, largest = 2, 1
    while factor * factor <= n:
        while n % factor == 0:
            largest, n = factor, n // factor
        factor += 1
    return max(largest, n)


def trace(omega_rad_s: float, rng: np.random.Generator) -> np.ndarray:
    """The steady resistance at ``omega_rad_s``, 50 kHz, with 0.2 % white noise: the blocks'
    samples end to end."""
    from signatelec.config.scene import Scene
    from signatelec.engines.simulate import simulate

    n = int(round(WINDOW_S * SAMPLE_RATE_HZ)) * BLOCK_WINDOWS * BLOCKS
    scene = Scene().with_overrides(
        radial_load_n=5820.0,
        clearance_m=8e-6,
        omega_rad_s=omega_rad_s,
        duration_s=0.01 + 1.05 * n / SAMPLE_RATE_HZ,
        sample_rate_hz=SAMPLE_RATE_HZ,
        fidelity="quasistatic",
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = simulate(scene).steady()["resistance_ohm"].to_numpy()[-n:]
    return r * (1.0 + NOISE_FRACTION * rng.standard_normal(r.size))


def measure(speeds: np.ndarray, passes: int, log=print) -> pd.DataFrame:
    from threadpoolctl import threadpool_limits

    from signatelec.estimation.analysis import analyse_windows

    n = int(round(WINDOW_S * SAMPLE_RATE_HZ))
    rows = []
    rng = np.random.default_rng(20261124)
    with threadpool_limits(limits=1, user_api="blas"):
        for omega in speeds:
            x = trace(float(omega), rng).reshape(BLOCKS, BLOCK_WINDOWS, n)
            first = analyse_windows(x[0], SAMPLE_RATE_HZ, float(omega))
            for block in x[1:]:
                analyse_windows(block, SAMPLE_RATE_HZ, float(omega))
            cpu = []
            for _ in range(passes):
                clock = time.process_time()
                for block in x:
                    analyse_windows(block, SAMPLE_RATE_HZ, float(omega))
                cpu.append((time.process_time() - clock) / (BLOCKS * BLOCK_WINDOWS))
            nper = int(round(4 * SAMPLE_RATE_HZ / first[0].ball_pass_hz))
            rows.append(
                {
                    "omega_rad_s": float(omega),
                    "segment_samples": nper,
                    "largest_prime_factor": largest_prime_factor(nper),
                    "analysis_us_per_window": 1e6 * float(np.median(cpu)),
                    "analysis_us_spread": 1e6 * float(np.max(cpu) - np.min(cpu)),
                }
            )
            log(
                f"  {omega:6.1f} rad/s  nper {nper:4d}  "
                f"{rows[-1]['analysis_us_per_window']:7.0f} us a window"
            )
    return pd.DataFrame(rows)


def draw(table: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from signatelec.plots import save_figure

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 3.8))
    for label, part in table.groupby("label", sort=False):
        part = part.sort_values("omega_rad_s")
        ax.plot(part.omega_rad_s, part.analysis_us_per_window / 1e3, "o-", ms=3, label=label)
        bx.plot(part.largest_prime_factor, part.analysis_us_per_window / 1e3, "o", ms=4)
    ax.set_xlabel("speed (rad/s)")
    ax.set_ylabel("analysis CPU per 0.2 s window (ms)")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    ax.set_title("50 kHz, blocks of 10 windows", fontsize=9)
    bx.set_xscale("log")
    bx.set_xlabel("largest prime factor of the Welch segment's length")
    bx.set_ylim(bottom=0)
    bx.set_title("the same windows against the segment length's factors", fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--report", type=Path, default=ROOT / "docs" / "monitor")
    parser.add_argument("--label", default=None)
    parser.add_argument("--speeds", type=int, default=41)
    parser.add_argument("--passes", type=int, default=5)
    parser.add_argument("--redraw", action="store_true")
    args = parser.parse_args()
    store = args.report / "window_cost.parquet"
    if args.redraw:
        report(pd.read_parquet(store), args.report)
        return
    import signatelec
    from signatelec.studies.bench import host_in_words

    label = (
        args.label
        or subprocess.run(
            ["git", "-C", str(Path(signatelec.__file__).parent), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    )
    print(f"window analysis cost of {signatelec.__file__} ({label})")
    speeds = np.linspace(250.0, 750.0, args.speeds)
    table = measure(speeds, args.passes).assign(label=label, host=host_in_words())
    args.report.mkdir(parents=True, exist_ok=True)
    if store.exists():
        table = pd.concat([pd.read_parquet(store).query("label != @label"), table])
    tmp = store.with_suffix(".tmp")
    table.to_parquet(tmp, index=False)
    tmp.replace(store)
    report(table, args.report)


def report(table: pd.DataFrame, folder: Path) -> None:
    """``window_cost.png`` and ``window_cost.md`` of the rows of every label."""
    draw(table, folder / "window_cost.png")
    summary = (
        table.groupby(["label", "host"], sort=False)
        .analysis_us_per_window.describe()
        .reset_index()
        .rename(columns={"min": "min_us", "50%": "median_us", "max": "max_us", "count": "speeds"})
    )
    lines = [
        "# The window analysis's CPU cost across speeds",
        "",
        "Written by `python pipelines/window_cost.py` (its docstring says how). Process CPU per "
        "0.2 s window of a 50 kHz trace, BLAS kept to one thread, compilation left out.",
        "",
        "![cost](window_cost.png)",
        "",
        *markdown(summary[["label", "host", "speeds", "min_us", "median_us", "max_us"]]),
        "",
        *markdown(table[["label", *table.columns.drop(["label", "host"])]]),
        "",
    ]
    tmp = folder / "window_cost.md.tmp"
    tmp.write_text("\n".join(lines))
    tmp.replace(folder / "window_cost.md")


if __name__ == "__main__":
    main()
