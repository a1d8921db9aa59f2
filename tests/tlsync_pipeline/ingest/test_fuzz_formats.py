"""Property-based tests of the drone/robot/survey readers: damaged files give an InputError naming the file, never a
traceback.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from data_fixtures.gps_logs import log_fixes, walk_trajectory
from data_fixtures.target_logs import (
    write_airdata_csv,
    write_dataflash,
    write_dji_srt,
    write_kml_track,
    write_rtklib_pos,
    write_tlog,
    write_tum,
    write_ulog,
)
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest import FORMATS, ingest, read_log

FUZZ = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
WRITERS = {
    "ulog": lambda p, t, g, e: write_ulog(p, t, g),
    "dataflash": lambda p, t, g, e: write_dataflash(p, t, g),
    "tlog": lambda p, t, g, e: write_tlog(p, t, g),
    "rtklib": lambda p, t, g, e: write_rtklib_pos(p, t, g),
    "kml": lambda p, t, g, e: write_kml_track(p, t, g),
    "tum": lambda p, t, g, e: write_tum(p, t, e),
    "dji": lambda p, t, g, e: write_airdata_csv(p, t, g),
    "srt": lambda p, t, g, e: write_dji_srt(p, t, g, "mavic_pro"),
}


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Valid small logs of each format, as bytes."""
    folder = tmp_path_factory.mktemp("logs")
    walk = walk_trajectory(seconds=4.0, rate=5.0, gap=None)
    t, geo = log_fixes(walk, Origin(47.3769, 8.5417, 450.0), dt.datetime(2026, 3, 1, 12, tzinfo=dt.timezone.utc))
    return {fmt: write(folder / f"log.{fmt}", t, geo, walk.xyz).read_bytes() for fmt, write in WRITERS.items()}


def _run(path, fmt):
    """Read and ingest: either a trajectory of finite positions or an InputError that starts with the file's path."""
    try:
        with np.errstate(all="ignore"):
            trajectory, report = ingest(read_log(path, fmt))
    except InputError as exc:
        assert str(exc).startswith(str(path)), str(exc)
        return
    assert np.isfinite(trajectory.xyz).all()
    report.summary()


_BYTE_EDITS = st.lists(
    st.tuples(
        st.sampled_from(["flip", "cut", "insert", "delete"]), st.integers(0, 1 << 20), st.binary(min_size=1, max_size=8)
    ),
    min_size=1,
    max_size=4,
)


def _edit(data: bytes, edits) -> bytes:
    out = bytearray(data)
    for op, at, junk in edits:
        i = at % max(len(out), 1)
        if op == "flip" and out:
            out[i] ^= junk[0] or 1
        elif op == "cut":
            del out[i:]
        elif op == "insert":
            out[i:i] = junk
        elif op == "delete":
            del out[i : i + len(junk)]
    return bytes(out)


@FUZZ
@given(fmt=st.sampled_from(sorted(WRITERS)), edits=_BYTE_EDITS, detect=st.booleans())
def test_damaged_logs(tmp_path, logs, fmt, edits, detect):
    path = tmp_path / "damaged.log"
    path.write_bytes(_edit(logs[fmt], edits))
    _run(path, "auto" if detect else fmt)


@FUZZ
@given(data=st.binary(max_size=300), fmt=st.sampled_from([f for f in FORMATS if f != "rosbag"]))
def test_arbitrary_bytes_with_each_reader(tmp_path, data, fmt):
    path = tmp_path / "log.bin"
    path.write_bytes(data)
    _run(path, fmt)


@FUZZ
@given(
    prefix=st.sampled_from(
        [
            b"ULog\x01\x12\x35\x01",
            b"\xa3\x95\x80",
            b"\x0e\x10\x00\x00\x00\x00\x00\x00.FIT",
            b"\x00\x00\x00\x18ftypmp42",
            b"DEVC\x00\x01\x00\x10",
            b"<kml>",
            b"% (lat/lon/height=WGS84/ellipsoidal)\n",
            b"time(millisecond),datetime(utc),latitude,longitude\n",
            b"1\n00:00:00,000 --> 00:00:01,000\nGPS(",
        ]
    ),
    data=st.binary(max_size=300),
)
def test_magic_then_bytes(tmp_path, prefix, data):
    path = tmp_path / "log.bin"
    path.write_bytes(prefix + data)
    _run(path, "auto")
