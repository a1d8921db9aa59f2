"""Units of a log: declared ones convert, and a trajectory that cannot move like a target in seconds and metres is
named.
"""

from __future__ import annotations

import numpy as np
import pytest

from tlsync_pipeline.ingest.params import IngestParams
from tlsync_pipeline.ingest.process import in_seconds_and_metres, ingest
from tlsync_pipeline.ingest.records import LOCAL, make_records
from tlsync_pipeline.ingest.units import LENGTH_UNITS, TIME_UNITS, implausible_motion, unit_scale


def _walk(rate: float = 5.0, seconds: float = 120.0, speed: float = 1.4):
    t = np.arange(0.0, seconds, 1.0 / rate)
    return t, np.column_stack([speed * t, 3.0 * np.sin(t / 10.0), np.zeros_like(t)])


def test_units_by_name_or_number():
    assert unit_scale("ms", TIME_UNITS, "seconds") == 1e-3 and unit_scale(0.2, TIME_UNITS, "seconds") == 0.2
    assert unit_scale("ft", LENGTH_UNITS, "metres") == 0.3048
    for bad in ("feet", 0, -1.0, True, float("nan")):
        with pytest.raises(ValueError, match="expected one of"):
            unit_scale(bad, LENGTH_UNITS, "metres")


def test_a_walk_in_seconds_and_metres_is_plausible_and_in_milliseconds_it_is_named():
    t, xyz = _walk()
    assert implausible_motion(t, xyz) is None
    assert 'time_unit = "ms"' in implausible_motion(t * 1000.0, xyz)
    assert 'time_unit = "us"' in implausible_motion(t * 1e6, xyz)
    assert "length_unit" in implausible_motion(t, xyz * 1000.0)  # millimetres: 1.4 km/s


def test_a_log_in_milliseconds_and_feet_ingests_as_its_seconds_and_metres():
    t, xyz = _walk()
    rows = np.column_stack([t * 1000.0, xyz / 0.3048])
    records = make_records("walk.csv", "csv", LOCAL, rows.tolist(), list(range(2, len(t) + 2)), utc=False)
    assert np.allclose(in_seconds_and_metres(records, 1e-3, 0.3048).values, xyz)
    trajectory, report = ingest(records, IngestParams(time_unit=1e-3, length_unit=0.3048))
    assert trajectory.rate == pytest.approx(5.0) and np.allclose(trajectory.xyz[:, 0], xyz[:, 0], atol=1e-6)
    assert report.params["time_unit"] == 1e-3 and report.params["length_unit"] == 0.3048
