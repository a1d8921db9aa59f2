"""Garmin VIRB FIT: gps_metadata fix times to the millisecond (timestamp + timestamp_ms on the device clock, to UTC by
timestamp_correlation or by the whole-second utc_timestamp), the source stated in the report."""

from __future__ import annotations

import calendar

import numpy as np
import pytest

from data_fixtures.gps_logs import log_fixes, walk_trajectory
from data_fixtures.target_logs import write_fit_virb
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest import ingest, read_log

ORIGIN = Origin(47.3769, 8.5417, 450.0)
POWER_ON = calendar.timegm((2026, 3, 1, 11, 58, 0)) + 0.637


@pytest.fixture(scope="module")
def walk():
    """A 40 s walk logged at 10 Hz from 100.3 s after power-on (fix times are not on whole device seconds)."""
    return log_fixes(walk_trajectory(seconds=40.0, rate=10.0, gap=None), ORIGIN, POWER_ON + 100.3)


@pytest.mark.parametrize(
    "correlation, named",
    [
        ("ms", "timestamp_ms and system_timestamp_ms"),
        ("fractional", "fractional_timestamp and fractional_system_timestamp"),
    ],
)
def test_virb_device_clock_to_utc_by_timestamp_correlation(tmp_path, walk, correlation, named):
    t, geo = walk
    records = read_log(write_fit_virb(tmp_path / "virb.fit", t, geo, POWER_ON, correlation=correlation))
    assert records.format == "fit" and records.utc and records.unit == "gps_metadata message" and not records.warnings
    assert (
        np.abs(records.t - t).max() < 0.002
    )  # the whole-second utc_timestamp beside timestamp_ms would be up to 1 s off
    np.testing.assert_allclose(records.values[:, :2], geo[:, :2], atol=1e-6)
    assert any("timestamp_ms" in n for n in records.notes) and any(named in n for n in records.notes)
    _, report = ingest(records)
    assert report.rate == pytest.approx(10.0) and any("timestamp_correlation" in n for n in report.notes)


def test_virb_without_correlation_uses_the_whole_second_utc_timestamp(tmp_path, walk):
    t, geo = walk
    records = read_log(write_fit_virb(tmp_path / "virb.fit", t, geo, POWER_ON, correlation=None))
    assert records.utc and any("utc_timestamp" in n for n in records.notes)
    error = records.t - t
    assert (
        np.ptp(error) < 1e-6 and abs(error[0]) < 0.1
    )  # one offset for the run: spacing exact, UTC to the whole seconds' precision
