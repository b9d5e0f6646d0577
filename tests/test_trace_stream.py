"""Reading a Parquet trace in chunks: which row groups have their times made from statistics.

A row group declared sorted by time (Parquet's ``sorting_columns``) whose time statistics (ends,
count, no nulls) agree with uniform sampling continuing the record is read without its time
column; its times are made uniform between its ends. The
stored times here carry an interior jitter of 1e-4 of a step (ten times below the jitter
``prepare_trace`` accepts), so a made group differs from its stored times and a group read in
full equals them bit for bit.
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from signatelec.measurement.stream import read_chunks

STEP = 1e-3
ROWS = 1000  # per row group
JITTER = 1e-4  # of a step, interior samples only


def _groups(case: str) -> list[np.ndarray]:
    """Five row groups of times; group 2 broken as ``case`` says."""
    steps = [STEP] * 5
    if case == "rate":  # one group sampled 25 % slower
        steps[2] = 1.25 * STEP
    groups, start = [], 0.5
    for k, step in enumerate(steps):
        if case == "gap" and k == 2:  # one sample lost between groups 1 and 2
            start += STEP
        t = start + step * np.arange(ROWS)
        t[1:-1] += JITTER * STEP * np.where(np.arange(1, ROWS - 1) % 2, 1.0, -1.0)
        if case == "dropout" and k == 2:  # one sample lost inside: same ends, one fewer
            t = np.delete(t, ROWS // 2)
        if case == "null" and k == 2:
            t[ROWS // 2] = np.nan
        groups.append(t)
        start = t[-1] + STEP
    return groups


def _write(path, groups, statistics=True, sorted_by_time=True):
    schema = pa.schema([("time_s", pa.float64()), ("resistance_ohm", pa.float64())])
    sorting = [pq.SortingColumn(0)] if sorted_by_time else None
    with pq.ParquetWriter(
        path, schema, write_statistics=statistics, sorting_columns=sorting
    ) as writer:
        for t in groups:
            r = 3e-3 * (1.0 + 0.01 * np.sin(2000.0 * t))
            # from_pandas: NaN becomes a null, as a DataFrame's missing time is written
            time_s = pa.array(t, from_pandas=True)
            writer.write_table(pa.table([time_s, pa.array(r)], schema=schema))
    return path


def _read(path, groups):
    chunks = list(read_chunks(path, chunk_rows=300))
    t = np.concatenate([c.time_s for c in chunks])
    r = np.concatenate([c.resistance_ohm for c in chunks])
    sizes = [c.time_s.size for c in chunks]
    assert [c.first_row for c in chunks] == [sum(sizes[:k]) for k in range(len(sizes))]
    return np.split(t, np.cumsum([g.size for g in groups])[:-1]), r


@pytest.mark.parametrize(
    ("case", "read"),
    [
        ("uniform", {0}),
        ("dropout", {0, 2}),
        ("gap", {0, 2}),
        # group 3 is one group-2 step after group 2's end: read in full, the step found again
        ("rate", {0, 2, 3}),
        ("null", {0, 2}),
    ],
)
def test_groups_read_in_full_or_made(tmp_path, case, read):
    """The first group and every group whose statistics break uniform sampling are read in
    full (their times bit for bit); the others are uniform between their stored ends."""
    groups = _groups(case)
    times, r = _read(_write(tmp_path / "t.parquet", groups), groups)
    for k, (made, stored) in enumerate(zip(times, groups, strict=True)):
        if k in read:
            np.testing.assert_array_equal(made, stored)
            continue
        assert not np.array_equal(made, stored), k
        assert made[0] == stored[0] and made[-1] == pytest.approx(stored[-1], abs=1e-12)
        # uniform to the rounding of the times (1e-16 s), within the stored jitter of them
        assert np.ptp(np.diff(made)) < 1e-9 * STEP
        assert np.abs(made - stored).max() <= 1.01 * JITTER * STEP
    _, r_full = _read(_write(tmp_path / "n.parquet", groups, statistics=False), groups)
    np.testing.assert_array_equal(r, r_full)


def test_without_statistics_every_group_is_read(tmp_path):
    groups = _groups("uniform")
    times, _ = _read(_write(tmp_path / "t.parquet", groups, statistics=False), groups)
    for made, stored in zip(times, groups, strict=True):
        np.testing.assert_array_equal(made, stored)


def test_without_a_declared_sort_every_group_is_read(tmp_path):
    """Statistics alone cannot tell an ordered group from a reversed or shuffled one (same ends,
    same count): a group not declared sorted by time is read in full, and a reversed group keeps
    its stored times for prepare_trace to refuse."""
    groups = _groups("uniform")
    groups[2] = groups[2][::-1].copy()
    times, _ = _read(_write(tmp_path / "t.parquet", groups, sorted_by_time=False), groups)
    for made, stored in zip(times, groups, strict=True):
        np.testing.assert_array_equal(made, stored)
