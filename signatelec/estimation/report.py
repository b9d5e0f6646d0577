"""The estimate of one trace as text, JSON or a one-row Parquet table."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.estimation.diagnose import condition_line
from signatelec.estimation.domain import REFUSE_SCORE, WARN_SCORE
from signatelec.estimation.models import DEFAULT_COVERAGE
from signatelec.io import write_bytes_atomic
from signatelec.physics.regimes import REGIMES


def format_estimate(result: dict) -> str:
    """A readable summary of :func:`estimate`'s result."""
    cov = result.get("interval_coverage", DEFAULT_COVERAGE)
    tr = result["trace"]
    lines = [
        f"trace: {tr['source']}, {tr['n_samples']} samples at {tr['sample_rate_hz']:.6g} Hz "
        f"({tr['duration_s'] * 1e3:.4g} ms, {tr['ball_passes']:.1f} ball passes); level "
        f"{tr['level_ohm'] * 1e3:.4f} mOhm, noise {tr['noise_rms_rel'] * 100:.3g} %",
        _ripple_line(tr),
    ]
    for r in tr["repairs"]:
        lines.append(f"repaired: {r}")
    lines.append(f"estimate ({cov:.0%} intervals):")
    if "radial_load_n" in result:
        lines.append(
            f"  radial load F_r = {result['radial_load_n']:.0f} N  "
            f"[{result['radial_load_n_low']:.0f}, {result['radial_load_n_high']:.0f}]"
        )
    if "epsilon" in result:
        lines.append(
            f"  load parameter epsilon = {result['epsilon']:.3f}  "
            f"[{result['epsilon_low']:.3f}, {result['epsilon_high']:.3f}]"
        )
    if "clearance_m" in result:
        lines.append(
            f"  clearance = {result['clearance_m'] * 1e6:+.1f} um  "
            f"[{result['clearance_m_low'] * 1e6:+.1f}, {result['clearance_m_high'] * 1e6:+.1f}]"
        )
    if "regime" in result:
        probs = ", ".join(
            f"{r} {result[f'regime_probability_{r}']:.2f}"
            for r in REGIMES
            if f"regime_probability_{r}" in result
        )
        sure = "" if result.get("regime_confident", True) else ", uncertain"
        lines.append(f"  regime = {result['regime']}  ({probs}{sure})")
    line = condition_line(result)
    if line is not None:
        lines.append(line)
    if "in_domain_score" in result:
        lines.append(
            f"  in-domain score = {result['in_domain_score']:.2g}  (warning below {WARN_SCORE:g}, "
            f"refused below {REFUSE_SCORE:g})"
        )
    for note in result.get("notes", []):
        lines.append(f"note: {note}")
    return "\n".join(lines)


def _ripple_line(tr: dict) -> str:
    """The ball-pass frequency the estimate read, and the line the sanity layer found."""
    found = (
        f"ball-pass frequency: found {tr['ball_pass_found_hz']:.2f} Hz "
        f"(kinematic {tr['ball_pass_expected_hz']:.2f} Hz)"
    )
    status, fa = tr.get("ripple"), tr.get("ripple_false_alarm", 1.0)
    if status == "found":
        return f"{found}; ripple line false-alarm probability {fa:.1g}"
    if status == "harmonic":
        return f"{found}; ripple line at a harmonic only ({tr['ripple_hz']:.2f} Hz, {fa:.1g})"
    if status == "elsewhere":  # a defect's own line, outgrowing the ripple (see the notes)
        return (
            f"ball-pass frequency: kinematic {tr['ball_pass_expected_hz']:.2f} Hz; the strongest "
            f"line is at {tr['ripple_hz']:.2f} Hz (false-alarm probability {fa:.2g})"
        )
    return (
        f"ball-pass frequency: kinematic {tr['ball_pass_expected_hz']:.2f} Hz; no ripple line "
        f"found (false-alarm probability {fa:.2g} at best)"
    )


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(type(value).__name__)


def result_json(result: dict) -> str:
    return json.dumps(result, indent=2, default=_json_default)


def result_table(result: dict) -> pd.DataFrame:
    """One-row table of the estimate (nested notes flattened)."""
    flat = {k: v for k, v in result.items() if k not in ("trace", "model", "notes")}
    for k, v in result["trace"].items():
        flat[f"trace_{k}"] = "; ".join(v) if isinstance(v, list) else v
    flat["notes"] = "; ".join(result.get("notes", []))
    return pd.DataFrame([flat])


def write_result(result: dict, out: str | Path) -> None:
    """JSON (``.json``) or Parquet (``.parquet``) of the estimate, written atomically."""
    if Path(out).suffix.lower() in (".parquet", ".pq"):
        buf = io.BytesIO()
        result_table(result).to_parquet(buf, index=False)
        data = buf.getvalue()
    else:
        data = (result_json(result) + "\n").encode()
    write_bytes_atomic(out, data)
