"""``signatelec monitor`` and its Python function given careless input: one-line refusals
(TraceError, a ValueError) before any deep numpy error, and no confident answer from a trace
or a setting that cannot carry one. No model is trained here: each refusal comes before the
model is asked, and the summary's qualification is checked on window tables."""

from __future__ import annotations

import math
import os
import signal
import threading
import time
import warnings
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from signatelec.estimation.evidence import non_overlapping, stretches_and_changes
from signatelec.estimation.monitor import MonitorSettings, monitor_trace
from signatelec.estimation.monitor_report import qualify, qualify_alarms
from signatelec.estimation.monitor_settings import MAX_OVERLAP
from signatelec.interrupts import signals_deferred
from signatelec.measurement.files import read_trace
from signatelec.measurement.stream import read_chunks
from signatelec.measurement.traces import TraceError, minimum_sample_rate_hz, prepare_trace
from signatelec.physics.kinematics import expected_ball_pass_hz
from tests.cli_run import run_main

FS = 20000.0
OMEGA = 500.0


def _trace(path, seconds=1.0, fs=FS, **extra):
    """A ball-pass ripple at OMEGA (a cosine at f_bp with 0.2 % noise) as a Parquet file."""
    t = np.arange(int(seconds * fs)) / fs
    rng = np.random.default_rng(0)
    r = 3e-3 * (1 + 0.01 * np.cos(2 * np.pi * expected_ball_pass_hz(OMEGA) * t))
    r *= 1 + 0.002 * rng.standard_normal(t.size)
    pd.DataFrame({"time_s": t, "resistance_ohm": r, **extra}).to_parquet(path)
    return path


def _refused(path, **settings) -> str:
    # no model: each refusal comes before one is asked (the level screen is skipped without
    # a domain)
    with pytest.raises(TraceError) as info:
        monitor_trace(path, SimpleNamespace(domain=None), MonitorSettings(**settings))
    message = str(info.value)
    assert "\n" not in message
    return message


def test_spreadsheet_and_logger_formats_read_in_chunks(tmp_path):
    """A record read in chunks whatever the way its numbers and times are written (decimal
    commas, Parquet timestamps with or without a zone, durations, ISO 8601 text, a time of
    day): the same resistances, and its times in seconds (timestamps' after the first, the
    chunks' ``origin_utc``; a time of day's after its first midnight, past the next one too:
    a logger's clock without a date had been refused as a time that goes back a day)."""
    from tests.test_estimate import _formats

    t = np.arange(5000) / FS
    r = 3e-3 * (1 + 0.01 * np.cos(2 * np.pi * expected_ball_pass_hz(OMEGA) * t))
    stamped = ("stamps.parquet", "paris.parquet", "iso.csv", "european.csv")
    for name, path in _formats(pd.DataFrame({"time_s": t, "resistance_ohm": r}), tmp_path).items():
        chunks = list(read_chunks(path, chunk_rows=2000))
        assert len(chunks) > 1, name
        got = np.concatenate([c.time_s for c in chunks])
        start = {"clock.csv": 36000.0, "midnight.csv": 86399.9}.get(name, 0.0)
        if name == "text.parquet":  # (its first time missing)
            got, t_ok = got[1:], t[1:]
        else:
            t_ok = t
        # exact, but a time of day's 36000 or 86399.9 s less midnight (to 1.5e-11 s)
        np.testing.assert_allclose(
            got - start, t_ok, rtol=0, atol=2e-11 * (start > 0), err_msg=name
        )
        np.testing.assert_array_equal(np.concatenate([c.resistance_ohm for c in chunks]), r)
        hour = "09" if name == "paris.parquet" else "10"
        origin = f"2026-11-24T{hour}:00:00+00:00" if name in stamped else None
        assert {c.origin_utc for c in chunks} == {origin}, name


def test_a_followed_file_with_decimal_commas_is_read_once_its_rows_arrive(tmp_path):
    """A file followed from before its logger writes a row (its header alone): the decimal
    mark is read from the first rows, not from the header (they had been refused as text)."""
    path = tmp_path / "live.csv"
    path.write_text("time_s;resistance_ohm\n")

    def write():
        time.sleep(0.3)
        with open(path, "a") as fh:
            fh.writelines(
                f"{i / FS:.6f};{3e-3 + 1e-6 * i:.9f}\n".replace(".", ",") for i in range(50)
            )

    writer = threading.Thread(target=write)
    writer.start()
    chunks = list(read_chunks(path, follow=True, poll_s=0.02, idle_s=1.0))
    writer.join()
    np.testing.assert_allclose(np.concatenate([c.time_s for c in chunks]), np.arange(50) / FS)
    np.testing.assert_allclose(
        np.concatenate([c.resistance_ohm for c in chunks]), 3e-3 + 1e-6 * np.arange(50)
    )


@pytest.mark.parametrize("compression", ["gz", "bz2", "xz"])
def test_a_damaged_compressed_file_is_refused_in_one_line(tmp_path, compression):
    """A compressed CSV cut short (a logger stopped mid-write) or not compressed at all: one
    line naming the file and the damage, wherever it is met; --follow cannot read one."""
    t = np.arange(100000) / FS
    path = tmp_path / f"cut.csv.{compression}"
    pd.DataFrame({"time_s": t, "resistance_ohm": 3e-3 + 0 * t}).to_csv(path, index=False)
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    fake = tmp_path / f"fake.csv.{compression}"
    fake.write_text("time_s,resistance_ohm\n0,1\n")
    flipped = tmp_path / f"flipped.csv.{compression}"  # bytes damaged inside the stream
    data = bytearray(path.read_bytes())
    data[30:60] = bytes(b ^ 0x55 for b in data[30:60])
    flipped.write_bytes(bytes(data))
    for p in (path, fake, flipped):
        with pytest.raises(TraceError) as info:
            list(read_chunks(p))
        message = str(info.value)
        # (bzip2 may give out garbage before its block check: a header not found, one line)
        assert f"cannot be read as csv.{compression} (damaged or truncated: " in message or (
            compression == "bz2" and p == flipped and "no column" in message
        )
        assert "\n" not in message
        with pytest.raises(TraceError, match=f"cannot be read as csv.{compression} "):
            read_trace(p)
    with pytest.raises(TraceError, match="a compressed file cannot be read before its writer"):
        read_chunks(path, follow=True)


def test_a_time_column_without_a_time_is_named(tmp_path):
    """Every time missing (a logger's timestamps all NaT): named, where the record had been
    called shorter than a window; timestamps where the resistance is asked: named; a bare
    number among durations: named (it had been read as nanoseconds)."""
    path = tmp_path / "nat.parquet"
    stamps = pd.Series(pd.NaT, index=range(2000), dtype="datetime64[ns]")
    pd.DataFrame({"time_s": stamps, "resistance_ohm": np.full(2000, 3e-3)}).to_parquet(path)
    assert _refused(path, omega_rad_s=OMEGA).endswith("no time in its 2000 rows")
    message = _refused(
        path, omega_rad_s=OMEGA, resistance_column="time_s", time_column="resistance_ohm"
    )
    assert "column 'time_s' holds timestamps or durations; numbers only" in message
    # a bare number among durations: pandas reads '2' beside '0 days 00:00:01' as 2 ns
    times = pd.Series(pd.to_timedelta(np.arange(2000) / FS, unit="s")).astype(str)
    times[1500] = "2"
    path = tmp_path / "durations.csv"
    pd.DataFrame({"time_s": times, "resistance_ohm": np.full(2000, 3e-3)}).to_csv(path)
    assert _refused(path, omega_rad_s=OMEGA).endswith(
        "column 'time_s' holds a bare number at row 1500 ('2') among times of day or "
        "durations; write every time alike"
    )


@pytest.mark.parametrize("back_s", [3600.0, 1800.0, 86400.0])
def test_a_clock_set_back_an_hour_is_named_as_daylight_saving(tmp_path, back_s):
    """Local timestamps without a zone (read as UTC) across the autumn's change: the time goes
    back an hour within the first block, refused naming daylight saving and what to give (a
    step back of half an hour is not named so), by the monitor and by prepare_trace alike."""
    t = np.arange(int(2 * FS)) / FS
    t[int(FS) :] -= back_s
    stamps = pd.Timestamp("2026-10-25 02:59:59") + pd.to_timedelta(np.round(t * 1e9), unit="ns")
    path = tmp_path / "autumn.parquet"
    pd.DataFrame({"time_s": stamps, "resistance_ohm": np.full(t.size, 3e-3)}).to_parquet(path)
    named = "a local clock changed for daylight saving? give its timestamps with their UTC offset"
    with pytest.raises(TraceError) as info:
        prepare_trace(t, np.full(t.size, 3e-3), OMEGA)
    midnight = "the time goes back a day: a time of day past midnight? give dates too"
    for message in (_refused(path, omega_rad_s=OMEGA), str(info.value)):
        assert "time does not increase at row 20000" in message
        assert (named in message) is (back_s == 3600.0), message
        assert (midnight in message) is (back_s == 86400.0), message


def test_binary_file_given_as_csv(tmp_path):
    """Bytes that are no text: one line (was a UnicodeDecodeError traceback from pandas)."""
    path = tmp_path / "noise.csv"
    path.write_bytes(bytes(np.random.default_rng(1).integers(128, 256, 4000, dtype=np.uint8)))
    assert "cannot be read as csv" in _refused(path, omega_rad_s=OMEGA)


def test_directory_given_as_trace(tmp_path):
    (tmp_path / "run.parquet").mkdir()
    assert "is a directory" in _refused(tmp_path / "run.parquet", omega_rad_s=OMEGA)


def test_follow_gives_up_on_a_file_without_header(tmp_path):
    """--follow --idle on a file that never receives its header line ends after the idle time
    (it waited for ever)."""
    path = tmp_path / "live.csv"
    path.write_text("")
    clock = time.monotonic()
    with pytest.raises(TraceError, match="no header line"):
        list(read_chunks(path, follow=True, poll_s=0.02, idle_s=0.2))
    assert time.monotonic() - clock < 2.0


class _Pipe:
    """A pipe standing in for standard input, written by a thread in pieces with pauses."""

    def __init__(self, pieces, pause_s):
        read_fd, self.write_fd = os.pipe()
        self.buffer = os.fdopen(read_fd, "rb")
        self.sent = []  # (monotonic time, bytes so far) after each piece

        def write():
            done = 0
            for piece in pieces:
                os.write(self.write_fd, piece)
                done += len(piece)
                self.sent.append((time.monotonic(), done))
                time.sleep(pause_s)
            os.close(self.write_fd)

        self.thread = threading.Thread(target=write)
        self.thread.start()


def test_standard_input_is_read_as_it_arrives(monkeypatch):
    """``-`` reads CSV from standard input: every row once, in order, a line cut between two
    writes joined; each piece parsed within STREAM_WAIT_S of its arrival although the stream
    stays open (a stream read until a block filled held its rows until the writer closed, and
    Ctrl-C then lost them)."""
    t = np.arange(3000) / FS
    r = 3e-3 + 1e-6 * np.arange(3000)
    rows = "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, r, strict=True))
    text = ("time_s,resistance_ohm\n" + rows).encode()
    cuts = [0, 1000, 20011, 45017, len(text)]  # 20011, 45017: within lines
    pipe = _Pipe([text[a:b] for a, b in zip(cuts, cuts[1:], strict=False)], pause_s=3.0)
    monkeypatch.setattr("sys.stdin", pipe)
    seen, got = [], []
    for chunk in read_chunks("-"):
        seen.append(time.monotonic())
        got.append(chunk)
    pipe.thread.join()
    assert np.array_equal(np.concatenate([c.time_s for c in got]), t)
    assert np.array_equal(np.concatenate([c.resistance_ohm for c in got]), r)
    assert [c.first_row for c in got] == list(np.cumsum([0] + [c.time_s.size for c in got])[:-1])
    # the rows of each piece (after the header's) came before the next piece was written
    for (when, _), (after, _) in zip(pipe.sent[1:], pipe.sent[2:], strict=False):
        assert any(when <= s < after for s in seen), (pipe.sent, seen)


def test_standard_input_refusals(monkeypatch):
    """An empty stream: one line naming standard input; --idle (which ends a file that
    stopped growing) with ``-``: one line."""
    monkeypatch.setattr("sys.stdin", _Pipe([], pause_s=0.0))
    with pytest.raises(TraceError, match="^trace on standard input: .*no header line"):
        list(read_chunks("-"))
    message = _refused("-", omega_rad_s=OMEGA, follow=True, follow_idle_s=2.0)
    assert message.startswith("--idle 2.0: ") and "standard input is read to its end" in message


def test_standard_input_header_is_checked_before_the_model(monkeypatch, tmp_path, capsys):
    """A stream whose header lacks a column is refused before the model is asked for (the
    default model's first build takes minutes), in one line; a good header is left in the
    stream, whose every row is then read."""
    import signatelec.estimation.persistence as persistence
    from signatelec.measurement.stream import check_trace_file

    def no_model(*args, **kwargs):
        raise AssertionError("the model was asked for before the header was checked")

    monkeypatch.setattr(persistence, "default_model", no_model)
    text = b"# logger 7\ntime_s,resistance\n0.0,0.003\n"
    monkeypatch.setattr("sys.stdin", _Pipe([text], pause_s=0.0))
    code = run_main(["monitor", "-", "--out", str(tmp_path / "out"), "--omega", "500"])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "trace on standard input" in line and "resistance_ohm" in line, line
    assert not (tmp_path / "out").exists()
    # a stream whose first bytes are late (a logger waiting for its trigger) does not hold up
    # what else is checked before it: a model file that cannot be used is named at once
    junk = tmp_path / "junk.model"
    junk.write_bytes(b"not a model")
    late = _Pipe([b"", text], pause_s=5.0)
    monkeypatch.setattr("sys.stdin", late)
    clock = time.monotonic()
    code = run_main(
        ["monitor", "-", "--out", str(tmp_path / "o2"), "--omega", "500", "--model", str(junk)]
    )
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "junk.model" in line and time.monotonic() - clock < 4.0, line
    late.thread.join()
    rows = "".join(f"{i / FS!r};{3e-3 + 1e-6 * i!r}\n" for i in range(500))
    monkeypatch.setattr("sys.stdin", _Pipe([f"time_s;resistance_ohm\n{rows}".encode()], 0.0))
    check_trace_file("-")
    chunks = list(read_chunks("-"))
    assert sum(c.time_s.size for c in chunks) == 500 and chunks[0].time_s[1] == 1 / FS


def test_hop_overlap_bounded(tmp_path):
    """A hop far below the window multiplies the windows of a block analysed together (a hop
    of 1e-5 s on 0.2 s windows at 20 kHz was killed for lack of memory): refused beyond
    MAX_OVERLAP windows per sample."""
    message = _refused(tmp_path / "x.parquet", omega_rad_s=OMEGA, window_s=0.2, hop_s=1e-5)
    assert message.startswith("--hop 1e-05") and f"/ {MAX_OVERLAP}" in message


def test_hop_below_one_sample(tmp_path):
    """A hop shorter than the sampling step would give every window of a block the same
    samples (a hop of round(hop fs) = 0 samples)."""
    path = _trace(tmp_path / "slow.parquet", fs=2000.0)
    message = _refused(path, omega_rad_s=OMEGA, window_s=0.0125, hop_s=0.0003)
    assert message.startswith("--hop 0.0003") and "at least one sample" in message


def test_window_needs_the_ball_passes_of_estimate(tmp_path):
    """A window of 2 ball passes (5 ms at 500 rad/s, f_bp = 409.7 Hz) is refused as estimate
    refuses a trace under 5; with a speed column the windows say so."""
    f_bp = expected_ball_pass_hz(OMEGA)
    message = _refused(tmp_path / "x.parquet", omega_rad_s=OMEGA, window_s=0.005)
    assert message.startswith("--window 0.005") and f"{0.005 * f_bp:.3g} ball passes" in message
    path = _trace(tmp_path / "speed.parquet", speed=np.full(int(FS), OMEGA))
    message = _refused(path, speed_column="speed", window_s=0.005)
    assert "none of its" in message and "a window needs at least 5" in message


def test_missing_speed_column_without_numpy_warning(tmp_path):
    """A speed column without a value: one refusal, and no RuntimeWarning line on stderr."""
    path = _trace(tmp_path / "speed.parquet", speed=np.full(int(FS), np.nan))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert "speed nan rad/s" in _refused(path, speed_column="speed")


def test_speed_beyond_the_sampling_named_before_gaps():
    """--omega 1e9 at 20 kHz: the aliasing is named (it was read as a gap between every pair
    of samples, the gap limit being a quarter of a 1 ns ball pass)."""
    t = np.arange(4000) / FS
    with pytest.raises(TraceError, match="would alias") as info:
        prepare_trace(t, np.full(t.size, 3e-3), 1e9)
    assert f"{minimum_sample_rate_hz(1e9):.4g} Hz needed" in str(info.value)


def _windows(n, hop, window, seed=0, ripple="found", omega=OMEGA, shift_at=None, snr=100.0):
    """A window table of one state whose features are window means of white sample noise, so
    that overlapping windows share their samples as on a trace (``shift_at``: index of the
    window from which F_r and the level step up by 10 %)."""
    rng = np.random.default_rng(seed)
    per = 4  # samples per hop
    span = int(round(window / hop)) * per
    noise = rng.standard_normal((4, n * per + span))
    kernel = np.ones(span) / span
    means = np.stack([np.convolve(x, kernel, mode="valid")[: n * per : per] for x in noise])
    start = np.arange(n) * hop
    step = np.where(np.arange(n) >= (shift_at if shift_at is not None else n), 1.1, 1.0)
    load = 5000.0 * step * (1 + 0.005 * means[1])
    return pd.DataFrame(
        {
            "start_s": start,
            "end_s": start + window,
            "time_s": start + 0.5 * window,
            "status": "ok",
            "ripple": ripple,
            "omega_rad_s": omega,
            "in_domain_score": 0.5,
            "level_mean_ohm": 3e-3 / step * (1 + 0.002 * means[0]),
            "radial_load_n": load,
            "radial_load_n_low": load * 0.99,
            "radial_load_n_high": load * 1.01,
            "epsilon": 0.5 + 0.01 * means[2],
            "epsilon_low": 0.45 + 0.01 * means[2],
            "epsilon_high": 0.55 + 0.01 * means[2],
            "h1_rel": 1e-3 * (1 + 0.05 * means[3]),
            "h2_rel": np.full(n, 1e-4),
            "harmonic_snr": snr,
            "regime_probability_zero": 0.9,
            "regime_probability_preload": 0.1,
        }
    )


def test_overlapping_windows_do_not_split_a_constant_record():
    """A minute of one state at a quarter-window hop (windows sharing 3/4 of their samples):
    no change at 0.1 per hour (the detector read the overlap's smoothness as precision and
    split such a record of the quasi-static tier 48 times), and a 10 % step still found within
    one window of its time."""
    hop, window = 0.05, 0.2
    for seed in range(3):
        stretches, changes, _ = stretches_and_changes(_windows(1200, hop, window, seed), hop)
        assert changes == [] and len(stretches) == 1
    _, changes, _ = stretches_and_changes(_windows(1200, hop, window, 7, shift_at=600), hop)
    assert [c["time_s"] for c in changes] == pytest.approx([30.0], abs=window)


def test_non_overlapping_windows_kept():
    table = _windows(40, 0.05, 0.2)
    kept = non_overlapping(table)
    assert kept["start_s"].to_numpy() == pytest.approx(np.arange(10) * 0.2)


@pytest.mark.parametrize(
    ("ripple", "snr", "omega", "warned"),
    [
        ("found", 100.0, OMEGA, None),
        ("none", 100.0, OMEGA, "no ball-pass line"),
        # a harmonic SNR of 2 in every window is no warning: held-out DEM states whose ripple
        # lies below 0.2 % noise show 2-7 (as white noise does) and are read right
        ("found", 2.0, OMEGA, None),
        ("found", 100.0, 1000.0, "outside the training range 250-750"),
    ],
)
def test_stretch_qualified(ripple, snr, omega, warned):
    """A stretch of windows without a ball-pass line (the ripple screen's verdict) or at a speed
    outside the model's training range is not a confident regime call, and the summary's
    notes say why."""
    table = _windows(100, 0.2, 0.2, ripple=ripple, omega=omega, snr=snr)
    stretches, _, _ = stretches_and_changes(table, 0.2)
    notes = qualify(stretches, {"omega_rad_s": (250.0, 750.0)})
    (stretch,) = stretches
    assert stretch["regime_probability"] > 0.99
    if warned is None:
        assert stretch["regime_confident"] and stretch["warnings"] == [] and notes == []
    else:
        assert not stretch["regime_confident"]
        assert len(notes) == 1 and warned in notes[0] and notes[0].startswith("stretch 0-20 s")


@pytest.mark.parametrize("omega_after", [OMEGA, 1.2 * OMEGA])
def test_a_change_names_the_speed_that_changed_with_it(omega_after):
    """A 10 % load step where the speed also steps by 20 % (a speed column's): the change and
    its alarm say the speed changed too (a speed step alone reads as a change of the features,
    named as a load change below the thresholds); a speed that stays is not named."""
    table = _windows(100, 0.2, 0.2, shift_at=50)
    table.loc[50:, "omega_rad_s"] = omega_after
    _, changes, alarms = stretches_and_changes(table, 0.2)
    (change,) = changes
    (alarm,) = alarms
    named = f"the speed changed too: {OMEGA:g} -> {omega_after:g} rad/s"
    assert (named in change["what"]) is (omega_after != OMEGA)
    assert (named in alarm["what"]) is (omega_after != OMEGA)
    assert change["what"].startswith("load")


def test_signals_deferred_after_the_output_is_written():
    """Ctrl-C after the output is in place does not turn a finished run into exit 130 (it was
    "interrupted" with the new output written); the handler is restored afterwards."""
    before = signal.getsignal(signal.SIGINT)
    with signals_deferred():
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
    assert signal.getsignal(signal.SIGINT) is before


@pytest.mark.parametrize(
    ("hop", "rate", "threshold", "named"),
    [
        (0.2, math.nan, 0.05, "--false-alarm-rate nan"),
        (0.2, 0.1, -1.0, "--load-threshold -1.0"),
        (0.2, 0.1, math.nan, "--load-threshold nan"),
        (math.nan, 0.1, 0.05, "--hop nan"),
    ],
)
def test_evidence_settings_refused(hop, rate, threshold, named):
    """The Python function refuses what the command refuses, with its line (a NaN rate split
    a two-state record into 32 stretches; a negative threshold was a math domain error)."""
    with pytest.raises(ValueError, match="must be in") as info:
        stretches_and_changes(_windows(300, 0.2, 0.2, shift_at=150), hop, rate, threshold)
    assert str(info.value).startswith(named)


def test_settings_refused_as_by_the_command():
    """Both speeds, or tracking without --omega: refused by the settings themselves (the
    Python function took the speed column silently)."""
    for settings, named in (
        (MonitorSettings(omega_rad_s=OMEGA, speed_column="speed"), "give the speed one way"),
        (MonitorSettings(speed_column="speed", track_speed=True), "--track-speed"),
        (MonitorSettings(omega_rad_s=OMEGA, follow=True, follow_idle_s=0.0), "--idle 0.0"),
        (MonitorSettings(omega_rad_s=OMEGA, follow_idle_s=1.0), "give --follow too"),
    ):
        with pytest.raises(TraceError, match=named):
            settings.check()


def test_time_in_milliseconds_named(tmp_path):
    """A time column in ms reads as 20 Hz sampling: the refusal asks about its unit."""
    t = np.arange(4000) / FS * 1e3
    path = tmp_path / "ms.parquet"
    pd.DataFrame({"time_s": t, "resistance_ohm": np.full(t.size, 3e-3)}).to_parquet(path)
    message = _refused(path, omega_rad_s=OMEGA)
    assert message.startswith("--window 0.2: 4.0 samples at 20 Hz")
    assert "is --time-column 'time_s' in seconds?" in message


def test_alarm_into_a_stretch_without_line_not_confident():
    """A 10 % load step into windows where the ripple screen finds no line (a speed gone
    wrong): the alarm is raised, marked not confident; the step between two clean stretches
    stays confident."""
    lost = np.r_[np.full(150, "found"), np.full(150, "none")]
    for ripple, confident in (("found", True), (lost, False)):
        table = _windows(300, 0.2, 0.2, seed=3, shift_at=150, ripple=ripple)
        stretches, _, alarms = stretches_and_changes(table, 0.2)
        qualify(stretches)
        qualify_alarms(alarms, stretches)
        assert [a["kind"] for a in alarms] == ["load"]
        assert alarms[0]["confident"] is confident


def test_wrong_speed_column_named(tmp_path):
    """A speed column whose speed the ripple contradicts (a ripple at 500 rad/s, the column
    300 rad/s): the refusal names the column and its median over the screened samples, the
    first 0.5 s (it said "for --omega 300", an option the user did not give)."""
    path = _trace(tmp_path / "speed.parquet", speed=np.full(int(FS), 300.0))
    message = _refused(path, speed_column="speed")
    assert "--omega" not in message
    assert f"expected {expected_ball_pass_hz(300.0):.1f} Hz for --speed-column 'speed' " in message
    assert "(its median 300 rad/s over 0-0.5 s)" in message
    assert "the trace's speed is about 500 rad/s" in message


@pytest.mark.parametrize(
    ("unit", "settings"),
    [("Hz", {"omega_rad_s": OMEGA / (2 * math.pi)}), ("rpm", {"speed_column": "speed"})],
)
def test_a_speed_in_another_unit_is_named(tmp_path, unit, settings):
    """A speed given in Hz (--omega) or a speed column in rpm, read as rad/s: the ripple lies
    2 pi times above, or 60 / (2 pi) times below, the line expected, beyond the wide search.
    The refusal names the unit and the speed in rad/s (it had answered, warned that no line
    was found)."""
    rpm = OMEGA * 60 / (2 * math.pi)
    path = _trace(tmp_path / "unit.parquet", fs=100000.0, speed=np.full(100000, rpm))
    message = _refused(path, **settings)
    assert "the trace's speed is about 500 rad/s" in message
    given = OMEGA / (2 * math.pi) if unit == "Hz" else rpm
    assert f"was the speed given in {unit}? ({given:g} {unit} is 500 rad/s)" in message


def test_window_longer_than_the_training_windows_not_confident():
    """3 s windows (the training windows are at most 0.2 s, so harmonic_snr and
    duration_ball_passes, which grow with the length, lie beyond what the model saw): answered,
    with one note, and no stretch or alarm confident; 0.2 s windows are not warned of."""
    table = _windows(40, 3.0, 3.0, seed=3, shift_at=20)
    for window_s, warned in ((3.0, True), (0.2, False)):
        stretches, _, alarms = stretches_and_changes(table, 3.0)
        notes = qualify(stretches, {"omega_rad_s": (250.0, 750.0)}, window_s)
        qualify_alarms(alarms, stretches)
        assert len(stretches) == 2 and [a["kind"] for a in alarms] == ["load"]
        assert all(s["regime_confident"] is not warned for s in stretches)
        assert alarms[0]["confident"] is not warned
        if warned:
            (note,) = notes
            assert note.startswith("--window 3 s is longer than the training windows (at most")
            assert "harmonic_snr" in note and "duration_ball_passes" in note
        else:
            assert notes == []


@pytest.mark.parametrize(
    ("name", "args", "named"),
    [
        ("ok.parquet", ["--speed-column", "v"], "no column 'v'"),
        ("ok.csv", ["--omega", "500", "--time-column", "t"], "no column 't'"),
        ("none.parquet", ["--omega", "500"], "no such file"),
        ("ok.h5", ["--omega", "500"], "unknown format '.h5'"),
    ],
)
def test_trace_refused_before_the_model(tmp_path, capsys, monkeypatch, name, args, named):
    """A trace that can be refused from its name, footer or header is refused before the model
    is loaded or built (a first-time build takes minutes), with the line of the reader."""
    from signatelec.estimation import persistence

    def no_model(*_args, **_kwargs):
        raise AssertionError("the model was loaded before the trace was checked")

    monkeypatch.setattr(persistence, "default_model", no_model)
    monkeypatch.setattr(persistence, "load_model", no_model)
    path = tmp_path / name
    frame = pd.DataFrame({"time_s": np.arange(100) / FS, "resistance_ohm": np.full(100, 3e-3)})
    if name.endswith(".parquet"):
        frame.to_parquet(tmp_path / "ok.parquet")
    else:
        frame.to_csv(path, index=False)
    out = tmp_path / "out"
    code = run_main(["monitor", str(path), "--out", str(out), "--quiet", *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and named in err[0], err
    assert err[0].startswith(f"signatelec: error: trace {str(path)!r}: ")
    assert not out.exists()


def test_idle_must_be_finite_and_too_short_in_grammar(tmp_path):
    """--idle inf would follow for ever, which is --follow without --idle: refused with that
    said; a trace of one sample is "1 sample"."""
    with pytest.raises(TraceError) as info:
        MonitorSettings(omega_rad_s=OMEGA, follow=True, follow_idle_s=math.inf).check()
    assert str(info.value).startswith("--idle inf: must be a finite duration > 0 s")
    path = tmp_path / "one.parquet"
    pd.DataFrame({"time_s": [0.0], "resistance_ohm": [3e-3]}).to_parquet(path)
    assert "1 sample, shorter than one --window of 0.2 s" in _refused(path, omega_rad_s=OMEGA)


def test_evidence_settings_accept_numpy_numbers():
    """Settings given as numpy scalars (a hop read from a table, a rate from an array) are
    numbers like any other: the same stretches as with Python floats."""
    windows = _windows(300, 0.2, 0.2, shift_at=150)
    as_python = stretches_and_changes(windows, 0.2, 0.1, 0.05)
    as_numpy = stretches_and_changes(windows, np.float32(0.2), np.int64(1) / 10, np.float64(0.05))
    assert [s["start_s"] for s in as_numpy[0]] == [s["start_s"] for s in as_python[0]]
    with pytest.raises(ValueError, match="--hop True"):
        stretches_and_changes(windows, True, 0.1, 0.05)


@pytest.mark.parametrize(
    ("header", "column", "refused"),
    [
        ("time_s,r.1,r", "r.1", None),  # a real name that pandas' renaming also makes
        ("time_s,r,r", "r", "2 columns named 'r'"),
        ("time_s,1,1.5", "1", None),
    ],
)
def test_columns_named_twice(tmp_path, header, column, refused):
    """A column named twice is refused in one line (which one is meant cannot be told), from
    the header as written: pandas renames a repeated "r" to "r.1", which a real column may
    be called too, and is then read. Parquet names are the file's own."""
    rows = "".join(f"{i / FS!r},0.003,0.004\n" for i in range(100))
    path = tmp_path / "cols.csv"
    path.write_text(f"{header}\n{rows}")
    names = ("time_s", column)
    if refused:
        with pytest.raises(TraceError, match=refused):
            list(read_chunks(path, *names))
    else:
        assert len(next(iter(read_chunks(path, *names))).resistance_ohm) == 100
    frame = pd.DataFrame(np.zeros((4, 3)), columns=["time_s", "r.1", "r"])
    frame.to_parquet(tmp_path / "cols.parquet")
    assert len(next(iter(read_chunks(tmp_path / "cols.parquet", "time_s", "r.1"))).time_s) == 4


def test_lines_ending_in_a_carriage_return_alone(tmp_path):
    """A CSV whose lines end in CR alone (the old Mac convention) is one line to a reader of
    lines: one refusal naming the line ends (it was read as a header and no rows: "0 samples,
    shorter than one --window"), after at most a megabyte of it."""
    path = tmp_path / "mac.csv"
    path.write_bytes(b"time_s,resistance_ohm\r" + b"".join(
        f"{i / FS!r},0.003\r".encode() for i in range(200000)))  # fmt: skip
    message = _refused(path, omega_rad_s=OMEGA)
    assert "carriage return alone" in message and message.startswith(f"trace {str(path)!r}")
    # followed as it is written (it waited for a line break for ever), and after a header
    # ending in LF (the rows piled up unparsed)
    with pytest.raises(TraceError, match="carriage return alone"):
        list(read_chunks(path, follow=True, poll_s=0.02))
    path.write_bytes(b"time_s,resistance_ohm\n" + path.read_bytes().split(b"\r", 1)[1])
    with pytest.raises(TraceError, match="near row 0 .*carriage return alone"):
        list(read_chunks(path))
    # a binary file given as CSV is named for what it is, not for a stray carriage return
    path.write_bytes(b"PAR1\x15\r\x00\xff\xfe\n" * 10)
    assert "carriage return" not in _refused(path, omega_rad_s=OMEGA)
