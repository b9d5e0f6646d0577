"""The monitor's acceptance measured again on more held-out banks: how precise is one bank's figure?

Usage::

    python pipelines/monitor_replication.py [--bank DIR] [--report FILE]

One acceptance bank of ``signatelec study monitor`` holds 72 states; a stretch's regime and its
F_r error are the model's error for its state, shared by all the stretches of that state, so
the bank's figures are uncertain by the spread over states (a state misread in three stretches
moves the regime share by two points). Here the acceptance is run as the study runs it (same
model, the shipped stretch ratios ``BIAS_RATIO``, 20 records of 6 stretches of 2-10 s and a
final constant stretch of 60 s, 0.2 % noise) on the acceptance bank (``BANK_SEED``) and on
:data:`REPLICATION_SEEDS` more banks of 72 states drawn alike, which informed nothing. The first
four seeds were fixed before any of their banks was drawn, the next four (:data:`FRESH_SEEDS`)
likewise, after the first four had been read and before the stretch model's intervals came from
a model of its own error: they are banks no choice of the monitor has seen. Every bank is
reported, none left out.
A bank's records are drawn with its seed + 1, as the study's are, which is also the next
bank's seed: the records of one bank and the states of the next share a random stream (each
bank's own figures are unaffected; consecutive seeds were kept as fixed beforehand).

Per bank and pooled: changes found within one window, spurious changes, stretches with F_r
within 1 %, regime right for stretches of 2 s or more, 90 % coverage; the pooled shares with a
90 % interval from a bootstrap over states within banks (Efron & Tibshirani 1993, ch. 6: the
state is the unit that errs), and the misread states.

DEM runs are cached under ``--bank`` (default ``/tmp/monitor-bank``: the acceptance states as
the study caches them, and ``replication-<seed>/``); about 2 min of CPU per bank on first run,
30 s after. The report goes to ``--report`` (default ``docs/monitor/replication.md``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd

#: Banks beyond the acceptance bank: seeds fixed before any was drawn.
FRESH_SEEDS = (20264105, 20264106, 20264107, 20264108)
REPLICATION_SEEDS = (20264101, 20264102, 20264103, 20264104, *FRESH_SEEDS)
#: Bootstrap resamples of the states.
BOOTSTRAP = 4000
#: Shares reported with their bootstrap interval: column of the matched stretches, and the
#: stretches it is taken over.
SHARES = {
    "load_within_1pct": "all",
    "regime_right": "long",
    "coverage_radial_load_n": "all",
    "coverage_epsilon": "all",
    "coverage_clearance_m": "all",
}


def bootstrap_interval(hits: pd.DataFrame, column: str, rng: np.random.Generator) -> tuple:
    """90 % percentile interval of the share of ``column`` over stretches, resampling the
    states (with all their stretches) within each bank."""
    per_state = (
        hits.dropna(subset=[column]).groupby(["bank", "state"])[column].agg(["sum", "count"])
    )
    shares = np.empty(BOOTSTRAP)
    banks = [g.to_numpy() for _, g in per_state.groupby(level="bank")]
    for b in range(BOOTSTRAP):
        total = np.zeros(2)
        for g in banks:
            total += g[rng.integers(0, len(g), len(g))].sum(axis=0)
        shares[b] = total[0] / total[1]
    return tuple(np.quantile(shares, [0.05, 0.95]))


def pooled_shares(hits: pd.DataFrame) -> pd.DataFrame:
    """Each of :data:`SHARES` over the stretches of ``hits``, with its bootstrap interval."""
    rng = np.random.default_rng(0)
    pooled = []
    for column, over in SHARES.items():
        values = hits[column].dropna()
        low, high = bootstrap_interval(hits, column, rng)
        pooled.append(
            {
                "measure": column,
                "stretches": len(values) if over == "long" else len(hits),
                "states": hits.loc[values.index].groupby(["bank", "state"]).ngroups,
                "share": float(values.mean()),
                "low_90": low,
                "high_90": high,
            }
        )
    return pd.DataFrame(pooled)


def run_bank(bank_dir: Path, seed: int, records_seed: int, model, log) -> tuple:
    from signatelec.studies.monitor import CONSTANT_S, N_RECORDS, run_records
    from signatelec.studies.monitor_records import BANK_STATES, dem_bank

    bank = dem_bank(bank_dir, log, BANK_STATES, seed)
    work = bank_dir / "records"
    work.mkdir(exist_ok=True)
    truth, changes, _ = run_records(bank, model, work, N_RECORDS, CONSTANT_S, None, records_seed)
    truth["epsilon_state"] = truth.state.map(bank.set_index("state").epsilon)
    return truth, changes


def misread(truth: pd.DataFrame) -> list[str]:
    long_ = truth[truth.length_s >= 2.0]
    wrong = long_[long_.regime_est != long_.regime]
    lines = []
    for state, g in wrong.groupby("state"):
        row = g.iloc[0]
        lines.append(
            f"state {state}: {row.regime} at {row.clearance_m * 1e6:+.2f} um (epsilon "
            f"{row.epsilon_state:.3f}, F_r {row.radial_load_n:.0f} N) called "
            f"{', '.join(sorted(set(g.regime_est)))} in {len(g)} of "
            f"{(long_.state == state).sum()} stretches"
        )
    return lines


def main() -> None:
    from monitor_bias import markdown

    from signatelec.estimation.persistence import default_model
    from signatelec.io import write_bytes_atomic
    from signatelec.studies.monitor_metrics import acceptance_figures, stretch_hits
    from signatelec.studies.monitor_records import BANK_SEED

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bank", default="/tmp/monitor-bank")
    parser.add_argument("--report", default="docs/monitor/replication.md")
    args = parser.parse_args()
    start = time.process_time()
    model = default_model(log=print)
    root = Path(args.bank)
    banks = {"acceptance": (root, BANK_SEED)}
    banks |= {f"replication {s}": (root / f"replication-{s}", s) for s in REPLICATION_SEEDS}
    rows, hits, wrong = [], [], []
    for name, (directory, seed) in banks.items():
        truth, changes = run_bank(directory, seed, seed + 1, model, print)
        rows.append(
            {"bank": name, "states": truth.state.nunique()} | acceptance_figures(truth, changes)
        )
        h = stretch_hits(truth)
        h["bank"] = name
        hits.append(h)
        wrong += [f"{name}, {line}" for line in misread(truth)]
        cpu = time.process_time() - start
        print(f"{name}: regime {rows[-1]['regime_right']:.3f}, {cpu:.0f} s CPU")
    table = pd.DataFrame(rows)
    hits = pd.concat(hits, ignore_index=True)
    fresh = hits[hits.bank.isin([f"replication {s}" for s in FRESH_SEEDS])]
    lines = [
        "# The monitor's acceptance on more held-out banks",
        "",
        "Written by `python pipelines/monitor_replication.py` (its docstring says how). "
        "The acceptance bank of `signatelec study monitor` and "
        f"{len(REPLICATION_SEEDS)} more banks of 72 states drawn alike (seeds "
        f"{', '.join(map(str, REPLICATION_SEEDS))}, each fixed before its bank was drawn), "
        "each monitored as the study's acceptance records are: 20 records of 6 stretches of "
        "2-10 s and a final constant stretch of 60 s, 0.2 % white noise, the default model and "
        "the shipped stretch ratios. No choice was made on a bank's figures; the acceptance "
        "bank and the first four replication banks were read before later changes were made "
        "on other evidence (docs/monitor/model_error.md, item 7), the last four "
        f"({', '.join(map(str, FRESH_SEEDS))}) only once the monitor was final.",
        "",
        "## Per bank",
        "",
        *markdown(table),
        "",
        "## Pooled, with a 90 % interval from a bootstrap over states within banks",
        "",
        *markdown(pooled_shares(hits)),
        "",
        f"The last {len(FRESH_SEEDS)} banks alone:",
        "",
        *markdown(pooled_shares(fresh)),
        "",
        f"Targets: F_r within 1 % for every stretch, regime right for >= 95 % of stretches of "
        f"2 s or more, 90 % coverage within 85-95 %. Pooled over {len(table)} banks: "
        f"{int(table.true_changes.sum())} true changes, "
        f"{(table.changes_within_window * table.true_changes).sum() / table.true_changes.sum():.1%}"
        f" found within one window; spurious changes {int(table.spurious_in_constant.sum())} on "
        f"{len(table) * 20} constant 60 s stretches, {int(table.spurious_elsewhere.sum())} "
        "elsewhere.",
        "",
        "## States called in the wrong regime (stretches of 2 s or more)",
        "",
        *[f"- {line}" for line in wrong],
        "",
        f"CPU {time.process_time() - start:.0f} s.",
        "",
    ]
    write_bytes_atomic(args.report, "\n".join(lines).encode())
    print(f"wrote {args.report}")


if __name__ == "__main__":
    main()
