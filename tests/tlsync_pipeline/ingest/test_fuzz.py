"""Property-based tests: no input makes a log parser raise anything but a clear InputError."""

from __future__ import annotations

import datetime as dt
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from data_fixtures.gps_logs import (
    walk_trajectory,
    write_csv_log,
    write_gpx_log,
    write_nmea_log,
)
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest import IngestParams, ingest, read_log
from tlsync_pipeline.ingest.records import GEODETIC, LOCAL, make_records

ORIGIN = Origin(47.3769, 8.5417, 450.0)
START = dt.datetime(2026, 3, 1, 12, 0, 0, tzinfo=dt.timezone.utc)
FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
FORMATS = ["auto", "gpx", "nmea", "csv", "odometry"]


WHOLE_FILE = (
    "empty log",
    "no valid fix",
    "no position fix",
    "only one valid fix",
    "cannot detect",
    "fewer than 2 fixes",
    "a time is wrong",
    "samples: check",
    "cannot read as a ROS bag",
    "needs the optional extra",
    "not a readable",
)


def _run(path, fmt):
    """Read and ingest; an InputError must name the file, and the line unless it is about the whole file."""
    try:
        trajectory, report = ingest(read_log(path, fmt))
    except InputError as exc:
        message = str(exc)
        assert message.startswith(str(path)), message
        names_line = re.match(re.escape(str(path)) + r"(:\d+: |: track point \d+: )", message)
        assert names_line or any(w in message for w in WHOLE_FILE), message
        return None
    assert len(trajectory) >= 1 and np.isfinite(trajectory.xyz).all()
    report.summary()
    return report


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Small valid logs of each format, as text."""
    folder = tmp_path_factory.mktemp("logs")
    walk = walk_trajectory(seconds=3.0, rate=5.0, gap=None)
    return {
        "gpx": write_gpx_log(folder / "w.gpx", walk, ORIGIN, START).read_text(),
        "nmea": write_nmea_log(folder / "w.nmea", walk, ORIGIN, START).read_text(),
        "csv": write_csv_log(folder / "w.csv", walk, ORIGIN, START).read_text(),
    }


@FUZZ
@given(data=st.binary(max_size=400), fmt=st.sampled_from(FORMATS))
def test_arbitrary_bytes(tmp_path, data, fmt):
    path = tmp_path / "log.bin"
    path.write_bytes(data)
    _run(path, fmt)


@FUZZ
@given(
    prefix=st.sampled_from(
        [b"$GPGGA,", b"time,lat,lon,alt\n", b"t,x,y,z\n", b"<?xml version='1.0'?><gpx version='1.1'><trk><trkseg>"]
    ),
    data=st.binary(max_size=300),
)
def test_plausible_start_then_bytes(tmp_path, prefix, data):
    path = tmp_path / "log.txt"
    path.write_bytes(prefix + data)
    _run(path, "auto")


_EDITS = st.lists(
    st.tuples(
        st.sampled_from(["cut", "replace", "insert", "delete", "duplicate", "swap"]),
        st.integers(0, 10_000),
        st.integers(0, 10_000),
        st.text(max_size=12),
    ),
    min_size=1,
    max_size=4,
)


def _mangle(text: str, edits) -> str:
    lines = text.split("\n")
    for op, a, b, junk in edits:
        i = a % len(lines)
        line = lines[i]
        if op == "cut":
            lines = lines[:i] + [line[: b % (len(line) + 1)]]
        elif op == "replace" and line:
            j = b % len(line)
            lines[i] = line[:j] + junk + line[j + 1 :]
        elif op == "insert":
            lines.insert(i, junk)
        elif op == "delete":
            del lines[i]
            lines = lines or [""]
        elif op == "duplicate":
            lines.insert(i, line)
        elif op == "swap":
            j = b % len(lines)
            lines[i], lines[j] = lines[j], lines[i]
    return "\n".join(lines)


@FUZZ
@given(fmt=st.sampled_from(["gpx", "nmea", "csv"]), edits=_EDITS, detect=st.booleans())
def test_mangled_lines(tmp_path, logs, fmt, edits, detect):
    path = tmp_path / f"mangled.{fmt}"
    path.write_text(_mangle(logs[fmt], edits), encoding="utf-8")
    _run(path, "auto" if detect else fmt)


@FUZZ
@given(
    t=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=0, max_size=30),
    values=st.lists(
        st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)), min_size=30, max_size=30
    ),
    geodetic=st.booleans(),
    rate=st.none() | st.floats(0.01, 100.0),
    smoothing=st.sampled_from([0.0, 1.0]),
)
def test_ingest_of_arbitrary_records(tmp_path, t, values, geodetic, rate, smoothing):
    values = np.asarray(values[: len(t)]).reshape(-1, 3)
    if geodetic:
        values = np.column_stack([np.clip(values[:, 0] / 20, -90, 90), values[:, 1] / 10, values[:, 2]])
    rows = np.column_stack([np.asarray(t, dtype=float).reshape(-1, 1), values]) if len(t) else np.zeros((0, 4))
    records = make_records(tmp_path / "r", "csv", GEODETIC if geodetic else LOCAL, rows, np.arange(1, len(t) + 1))
    try:
        with np.errstate(all="ignore"):
            trajectory, _ = ingest(records, IngestParams(rate=rate, smoothing_s=smoothing))
    except InputError as exc:
        assert str(tmp_path / "r") in str(exc)
        return
    assert np.isfinite(trajectory.xyz).all() and (np.diff(trajectory.sample) > 0).all()
