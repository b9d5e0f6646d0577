"""The monitoring study: long records assembled from paper-fidelity DEM runs, monitored.

:func:`run_study` (``signatelec study monitor --out docs/monitor``):

1. **bank** (:func:`~signatelec.studies.monitor_records.dem_bank`): held-out load states of the
   seed's 6208 at 500 rad/s, a third per regime, drawn like the training design
   (``datasets/load_state.toml``), one DEM run each at the paper's fidelity (velocity Verlet,
   dt = 1e-7 s), steady trace at 20 kHz, cached under the bank directory (``/tmp`` by default);
2. **records** (:func:`~signatelec.studies.monitor_records.assemble_record`): :data:`N_RECORDS`
   records of :data:`N_STRETCHES` stretches of 2-10 s and a final constant stretch of
   :data:`CONSTANT_S` (the false-alarm check), each stretch a state's steady segment tiled,
   with independent white noise;
3. **calibrate** the stretch intervals' model-error term
   (:data:`~signatelec.estimation.evidence.BIAS_RATIO`) on records assembled alike from a
   second bank of :data:`~signatelec.studies.monitor_records.CALIBRATION_STATES` states drawn
   from another seed (:func:`~signatelec.studies.monitor_metrics.calibrate_bias_ratio`: split
   conformal over their stretches);
4. **monitor** each acceptance record (:func:`signatelec.estimation.monitor.monitor_trace`),
   with the calibrated ratios, and compare change times, per-stretch F_r, regime and interval
   coverage with the truth, then the throughput and peak memory of ``signatelec monitor`` on
   synthetic 50 kHz records of 1, 10 and 60 minutes (:mod:`signatelec.studies.monitor_metrics`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.io import write_bytes_atomic
from signatelec.studies.monitor_records import (
    BANK_SEED,
    CALIBRATION_SEED,
    CALIBRATION_STATES,
    OMEGA_RAD_S,
    SAMPLE_RATE_HZ,
    assemble_record,
    dem_bank,
    write_record,
)

#: Records of the acceptance run: stretches per record before the final constant stretch.
N_RECORDS = 20
N_STRETCHES = 6
CONSTANT_S = 60.0
#: Records assembled from the calibration bank, drawn as the acceptance records are (a final
#: constant stretch too: a long stretch has almost no noise part, and a calibration without
#: such stretches under-covers them): ~4 stretches a state.
N_CALIBRATION_RECORDS = 160


def run_records(
    bank: pd.DataFrame,
    model,
    directory: Path,
    n_records: int = N_RECORDS,
    constant_s: float | None = CONSTANT_S,
    log: Callable[[str], None] | None = None,
    seed: int = BANK_SEED + 1,
    bias_ratio: dict | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """Monitor ``n_records`` assembled records (drawn with ``seed``; stretch intervals with
    ``bias_ratio``, as :func:`~signatelec.estimation.evidence.combine_stretch` takes it):
    (truth, found stretches, change statistics); with a stretch model, the statistics'
    ``windows_truth`` holds the same stretches answered by the windows' estimates combined."""
    from signatelec.estimation.evidence import stretches_and_changes
    from signatelec.estimation.monitor import MonitorSettings, monitor_trace
    from signatelec.studies.monitor_metrics import match_record

    rng = np.random.default_rng(seed)
    settings = MonitorSettings(omega_rad_s=OMEGA_RAD_S)
    rows, change_rows, window_rows = [], [], []
    cpu = seconds = 0.0
    example = None
    for i in range(n_records):
        noisy, truth = assemble_record(bank, rng, N_STRETCHES, constant_s)
        path = directory / f"record-{i:02d}.parquet"
        write_record(path, noisy, SAMPLE_RATE_HZ)
        table = monitor_trace(path, model, settings)
        path.unlink()
        windows = table.frame()
        stretches, changes, alarms = stretches_and_changes(
            windows,
            settings.hop,
            bias_ratio=bias_ratio,
            stretch_model=model.stretch,
            faulty_model=model.faulty,
        )
        cpu += table.cpu_s
        seconds += noisy.size / SAMPLE_RATE_HZ
        truth_m, chg = match_record(truth, stretches, changes, windows, settings.window_s)
        frames = [(truth_m, rows), (chg, change_rows)]
        if model.stretch is not None:  # the fallback, on the same change points
            alone = stretches_and_changes(
                windows, settings.hop, bias_ratio=bias_ratio, faulty_model=model.faulty
            )
            frames.append(
                (match_record(truth, *alone[:2], windows, settings.window_s)[0], window_rows)
            )
        for frame, out in frames:
            frame.insert(0, "record", i)
            out.append(frame)
        if example is None:
            example = (windows, table, settings, stretches, changes, alarms)
        if log:
            log(f"record {i}: {seconds:.0f} s of trace monitored, {cpu:.1f} s CPU")
    return (
        pd.concat(rows, ignore_index=True),
        pd.concat(change_rows, ignore_index=True),
        {
            "trace_s": seconds,
            "cpu_s": cpu,
            "example": example,
            "windows_truth": pd.concat(window_rows, ignore_index=True) if window_rows else None,
        },
    )


def run_study(
    out: str | Path,
    bank_dir: str | Path = "/tmp/monitor-bank",
    quick: bool = False,
    minutes: tuple[float, ...] = (1.0, 10.0, 60.0),
    log: Callable[[str], None] | None = None,
) -> dict[str, Path]:
    """The study (module docstring) into ``out``: monitor.md, monitor_stretches.parquet,
    monitor_calibration.parquet, monitor_changes.parquet, monitor_throughput.parquet,
    monitor_example.png."""
    from signatelec.estimation.monitor_report import draw, summary_of
    from signatelec.estimation.persistence import default_model
    from signatelec.studies.monitor_metrics import (
        acceptance_report,
        calibrate_bias_ratio,
        cross_validated_coverage,
        throughput_table,
    )

    start = time.time()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    bank = dem_bank(bank_dir, log=log)
    model = default_model(log=log)
    work = Path(bank_dir) / "records"
    work.mkdir(exist_ok=True)
    calibration = dem_bank(
        Path(bank_dir) / f"calibration-{CALIBRATION_SEED}",
        log,
        6 if quick else CALIBRATION_STATES,
        CALIBRATION_SEED,
    )
    n_cal = 2 if quick else N_CALIBRATION_RECORDS
    const = 10.0 if quick else CONSTANT_S
    cal_truth, _, cal_info = run_records(
        calibration, model, work, n_cal, const, log, CALIBRATION_SEED + 1
    )
    source = "windows" if model.stretch is None else "mean features"
    ratios = {source: calibrate_bias_ratio(cal_truth)}
    if cal_info["windows_truth"] is not None:
        ratios["windows"] = calibrate_bias_ratio(cal_info["windows_truth"])
    cross_validation = cross_validated_coverage(cal_truth)
    if log:
        log(f"calibrated bias ratios: {ratios}")
    n = 2 if quick else N_RECORDS
    truth, changes, info = run_records(bank, model, work, n, const, log, bias_ratio=ratios)
    info["bias_ratio"] = ratios
    info["bank"] = {"states": len(bank), "regimes": bank.regime.value_counts().to_dict()}
    info["calibration"] = {"states": len(calibration), "stretches": len(cal_truth)}
    info["cross_validation"] = cross_validation
    windows, table, settings, stretches, chg, alarms = info.pop("example")
    summary = summary_of(table, settings, stretches, chg, alarms, {}, model)
    paths = {"figure": out / "monitor_example.png"}
    draw(windows, summary, paths["figure"])
    throughput = throughput_table(bank, work, minutes=(0.25,) if quick else minutes, log=log)
    text = acceptance_report(truth, changes, info, throughput, time.time() - start)
    paths["report"] = out / "monitor.md"
    info["throughput"] = throughput.to_dict("records")
    write_bytes_atomic(paths["report"], text.encode())
    frames = (
        ("stretches", truth),
        ("calibration", cal_truth),
        ("changes", changes),
        ("throughput", throughput),
    )
    for name, frame in frames:
        paths[name] = out / f"monitor_{name}.parquet"
        buffer = frame.to_parquet()
        write_bytes_atomic(paths[name], buffer)
    return paths
