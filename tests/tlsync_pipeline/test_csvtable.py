"""The chunked numeric CSV reader: the same arrays and errors as reading line by line, Excel's CSVs accepted."""

from __future__ import annotations

import contextlib
import datetime as dt
import io
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from data_fixtures.gps_logs import walk_trajectory, write_csv_log
from data_fixtures.target_logs import write_tum
from tlsync_pipeline import csvtable
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest import read_log
from tlsync_pipeline.ingest.tum import read_tum
from tlsync_pipeline.trajectory import Trajectory, read_trajectory, write_trajectory

ORIGIN = Origin(47.3769, 8.5417, 450.0)
START = dt.datetime(2026, 3, 1, 12, 0, 0, tzinfo=dt.timezone.utc)
FUZZ = settings(
    max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


def _outcome(read, path, chunk_bytes: int, fast: bool):
    """What ``read(path)`` gives with chunks of ``chunk_bytes`` and the fast path on or off: its arrays or its error."""
    with contextlib.ExitStack() as stack:
        stack.enter_context(mock.patch.object(csvtable, "CHUNK_BYTES", chunk_bytes))
        if not fast:
            stack.enter_context(mock.patch.object(csvtable.Table, "_fast", lambda *args: None))
        try:
            result = read(path)
        except InputError as exc:
            return str(exc)
    if isinstance(result, Trajectory):
        return [result.sample, result.xyz, result.rate, result.t0, result.sigma]
    return [result.t, result.values, result.line, result.dropped, result.ignored, result.utc, result.warnings]


def _same(a, b) -> None:
    assert type(a) is type(b), (a, b)
    if isinstance(a, str):
        assert a == b
        return
    for x, y in zip(a, b):
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        else:
            assert x == y


def _trajectory_text(n: int = 40, sigma: bool = True) -> str:
    t = 1000.0 + np.arange(n) / 15.0
    xyz = np.column_stack([np.sin(t), np.cos(t), 0.01 * t])
    rows = [
        f"{a:.6f},{x:.4f},{y:.4f},{z:.4f}" + (f",{0.1 + 0.001 * i:.4f}" if sigma else "")
        for i, (a, (x, y, z)) in enumerate(zip(t, xyz))
    ]
    return ("t,x,y,z,sigma\n" if sigma else "t,x,y,z\n") + "\n".join(rows) + "\n"


_EDITS = st.lists(
    st.tuples(
        st.sampled_from(["replace", "insert", "delete", "duplicate", "cut"]),
        st.integers(0, 10_000),
        st.integers(0, 10_000),
        st.sampled_from(["", ",", "x", "nan", "-1", "1e999", " ", "\r", '"2"', "#c", ";", "0", "1.5.", "é"]),
    ),
    max_size=4,
)


def _mangle(text: str, edits) -> str:
    lines = text.split("\n")
    for op, a, b, junk in edits:
        i = a % len(lines)
        if op == "replace" and lines[i]:
            j = b % len(lines[i])
            lines[i] = lines[i][:j] + junk + lines[i][j + 1 :]
        elif op == "insert":
            lines.insert(i, junk)
        elif op == "delete" and len(lines) > 1:
            del lines[i]
        elif op == "duplicate":
            lines.insert(i, lines[i])
        elif op == "cut":
            lines = lines[: i + 1]
    return "\n".join(lines)


@FUZZ
@given(edits=_EDITS, sigma=st.booleans(), chunk=st.sampled_from([64, 300, 1 << 20]))
def test_trajectory_chunks_read_as_line_by_line(tmp_path, edits, sigma, chunk):
    path = tmp_path / "traj.csv"
    path.write_text(_mangle(_trajectory_text(sigma=sigma), edits), encoding="utf-8")
    _same(_outcome(read_trajectory, path, chunk, fast=True), _outcome(read_trajectory, path, 1 << 30, fast=False))


@FUZZ
@given(edits=_EDITS, chunk=st.sampled_from([64, 300, 1 << 20]))
def test_csv_log_chunks_read_as_line_by_line(tmp_path, edits, chunk):
    walk = walk_trajectory(seconds=4.0, rate=5.0, gap=None)
    path = write_csv_log(tmp_path / "walk.csv", walk, ORIGIN, START)
    path.write_text(_mangle(path.read_text(), edits), encoding="utf-8")
    _same(_outcome(read_log, path, chunk, fast=True), _outcome(read_log, path, 1 << 30, fast=False))


@FUZZ
@given(edits=_EDITS, chunk=st.sampled_from([64, 300, 1 << 20]))
def test_tum_chunks_read_as_line_by_line(tmp_path, edits, chunk):
    t = 1000.0 + np.arange(30) / 30.0
    path = write_tum(tmp_path / "poses.txt", t, np.column_stack([np.sin(t), np.cos(t), 0.01 * t]))
    path.write_text(_mangle(path.read_text(), edits), encoding="utf-8")
    _same(_outcome(read_tum, path, chunk, fast=True), _outcome(read_tum, path, 1 << 30, fast=False))


@pytest.mark.parametrize(
    "text, message",
    [
        ("x,y,z\n1,2,3\n1,2,oops\n", r":3: column 'z': not a number \(a 4-character field with letters\)"),
        ("x,y,z\n1,2,3\n1,2,\n", r":3: column 'z': not a number \(an empty field\)"),
        ("t,x,y,z\n0,1,2,3\n1,1,2,inf\n", r":3: column 'z': not a finite number \(NaN or infinity\)"),
        ("t,x,y,z,sigma\n0,1,2,3,1\n1,1,2,3,-0.5\n", r":3: column 'sigma': -0.5 m; a sigma must be positive"),
        ("t,x,y,z\n0,1,2,3\n1,1,2\n", r":3: expected 4 fields, got 3"),
    ],
)
def test_errors_name_line_and_column_without_quoting(tmp_path, text, message):
    path = tmp_path / "traj.csv"
    path.write_text(text)
    for chunk in (8, 1 << 20):
        with mock.patch.object(csvtable, "CHUNK_BYTES", chunk), pytest.raises(InputError, match=message) as info:
            read_trajectory(path)
        assert str(path) in str(info.value) and "oops" not in str(info.value)


def test_excel_csv_reads_as_the_plain_one(tmp_path):
    sample = np.arange(50.0)
    trajectory = Trajectory(
        sample, np.column_stack([sample * 0.5, -sample, np.full(50, 1.25)]), 10.0, 1_700_000_000.0, np.full(50, 0.02)
    )
    plain = tmp_path / "plain.csv"
    write_trajectory(trajectory, plain)
    excel = tmp_path / "excel.csv"
    excel.write_bytes(
        b"\xef\xbb\xbf" + plain.read_text().replace(",", ";").replace(".", ",").replace("\n", "\r\n").encode()
    )
    a, b = read_trajectory(plain), read_trajectory(excel)
    np.testing.assert_array_equal(a.xyz, b.xyz)
    np.testing.assert_array_equal(a.sample, b.sample)
    np.testing.assert_array_equal(a.sigma, b.sigma)
    assert (a.rate, a.t0) == (b.rate, b.t0)


def test_excel_csv_log_reads_as_the_plain_one(tmp_path):
    walk = walk_trajectory(seconds=4.0, rate=5.0, gap=None)
    plain = write_csv_log(tmp_path / "plain.csv", walk, ORIGIN, START)
    excel = tmp_path / "excel.csv"
    excel.write_bytes(
        b"\xef\xbb\xbf" + plain.read_text().replace(",", ";").replace(".", ",").replace("\n", "\r\n").encode()
    )
    a, b = read_log(plain, "csv"), read_log(excel, "csv")
    assert len(a) > 10 and not b.dropped
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.values, b.values)


def test_rows_written_in_blocks_as_savetxt_writes_them():
    rng = np.random.default_rng(3)
    halves = [0.03125, -0.5, 2.5, 0.00005, 1e-7 + 0.5e-6]  # exact halves (ties to even) and near ones
    edges = [-0.0, 0.0, 1e15, 2.0**53, -5e-5, 5e-5, 0.99999995, -0.99999, 9999.99995, np.nan, np.inf, -np.inf]
    columns = [
        1.7e9 + np.arange(40) / 30.0,
        rng.normal(0, 1e4, 40),
        np.r_[halves, edges, rng.normal(size=23)],
        rng.normal(0, 1, 40),
    ]
    formats = ["%.6f", "%.4f", "%.4f", "%.6f"]
    expected = io.StringIO()
    np.savetxt(expected, np.column_stack(columns), fmt=formats, delimiter=",")
    written = io.BytesIO()
    with mock.patch.object(csvtable, "WRITE_ROWS", 7):
        csvtable.write_rows(written, columns, [6, 4, 4, 6])
    assert written.getvalue().decode() == expected.getvalue()
    assert written.getvalue().count(b"\n") == 40


def test_fixed_point_rows_match_python_over_sixteen_magnitudes():
    rng = np.random.default_rng(4)
    values = np.concatenate([rng.normal(0, 10.0**k, 20_000) for k in range(-6, 10)])
    values[::1000] = np.round(values[::1000], 4) + 0.00005  # a tie in decimal, near one in binary
    text = csvtable.fixed_point_rows([values], [4]).decode()
    assert text.splitlines() == [f"{v:.4f}" for v in values.tolist()]
