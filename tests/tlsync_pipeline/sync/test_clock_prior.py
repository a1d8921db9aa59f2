"""A camera's own clock checks its line: agreement within the tolerance, a named flag when not, never a moved result."""

from __future__ import annotations

import pytest

from tlsync_pipeline.sync.clock_prior import CLOCK_FLAG, ClockPrior, check_clock, with_clock_checks
from tlsync_pipeline.sync.timeline import CameraLine, Timeline, read_timeline, write_timeline

T0 = 1_772_366_400.0  # the target log's first sample, UTC
RATE = 10.0  # samples/s


def _timeline() -> Timeline:
    """cam: 25 fps, frame 0 at sample 120 (12 s after T0): clock = 2.5 * sample - 300."""
    return Timeline(
        {"cam": CameraLine("cam", 2.5, -300.0, 400, 380, 0.4, fps=25.0, flags=())}, target_rate=RATE, target_t0=T0
    )


def test_a_right_prior_agrees_and_a_wrong_one_is_a_named_reason_not_obeyed(tmp_path):
    right = with_clock_checks(_timeline(), {"cam": ClockPrior(T0 + 12.4, 1.0, "QuickTime creationdate")}, log_utc=True)
    line = right.cameras["cam"]
    assert line.clock_check.agrees and line.clock_check.offset_s == pytest.approx(-0.4) and CLOCK_FLAG not in line.flags
    assert right.status("cam").status == "ok"
    wrong = with_clock_checks(_timeline(), {"cam": ClockPrior(T0 + 72.0, 1.0, "QuickTime creationdate")}, log_utc=True)
    line = wrong.cameras["cam"]
    assert (line.alpha, line.beta) == (2.5, -300.0)  # flagged, not moved
    assert CLOCK_FLAG in line.flags and line.clock_check.offset_s == pytest.approx(-60.0)
    status = wrong.status("cam")
    assert status.status == "weak" and "camera's own clock" in status.reason
    write_timeline(wrong, tmp_path / "timeline.json")
    back = read_timeline(tmp_path / "timeline.json").cameras["cam"]
    assert back.clock_check == line.clock_check and CLOCK_FLAG in back.flags


def test_no_comparison_when_the_log_is_not_on_utc():
    check = check_clock(_timeline().cameras["cam"], RATE, 3.5, False, ClockPrior(T0, 1.0, "GoPro GPSU"))
    assert check.agrees is None and check.result_utc_s is None
    timeline = with_clock_checks(_timeline(), {"cam": ClockPrior(T0 + 999.0, 1.0, "GoPro GPSU")}, log_utc=False)
    assert CLOCK_FLAG not in timeline.cameras["cam"].flags and timeline.cameras["cam"].clock_check.agrees is None


def test_the_results_own_interval_widens_the_tolerance():
    import dataclasses

    import numpy as np

    loose = dataclasses.replace(_timeline().cameras["cam"], cov=np.diag([0.0, 50.0**2]))  # beta +-50 frames: +-2 s
    check = check_clock(loose, RATE, T0, True, ClockPrior(T0 + 14.5, 1.0, "QuickTime creationdate"))
    assert check.result_half_width_s == pytest.approx(1.96 * 2.0) and check.agrees  # 2.5 s off: within 1 s + 3.9 s
    tight = check_clock(
        _timeline().cameras["cam"], RATE, T0, True, ClockPrior(T0 + 14.5, 1.0, "QuickTime creationdate")
    )
    assert tight.result_half_width_s == 0.0 and not tight.agrees


@pytest.mark.parametrize(
    "offset, text, remedy",
    [
        (
            7200.3,
            "+7200.3 s from the camera's own clock (the project; tolerance 1 s): +2 h, a clock on local time",
            "set [target] utc_offset = +2",
        ),
        (-5400.0, "-1.5 h, a clock on local time", "[cameras.clock] utc_offset = +1.5"),
        (
            18.2,
            "+18.2 s from the camera's own clock (the project; tolerance 1 s): +18 s, the leap seconds between GPS "
            "time and UTC",
            "a log on GPS time",
        ),
        (
            60.0,
            "+60.0 s from the camera's own clock (the project; tolerance 1 s)",
            "check the camera's clock and the log's time base",
        ),
    ],
)
def test_a_clock_disagreement_shows_its_offset_and_the_likely_key(offset, text, remedy):
    from tlsync_pipeline.sync.clock_prior import ClockCheck, clock_reason

    reason = clock_reason(ClockCheck("the project", 1e9, 1.0, 1e9 + offset, offset, False))
    assert text in reason.text and remedy in reason.remedy and reason.code == CLOCK_FLAG
