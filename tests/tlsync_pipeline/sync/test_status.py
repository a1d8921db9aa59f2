"""One status per camera: from its line's checks, flags, warnings and interval, or why it failed; the same back from
timeline.json.
"""

from __future__ import annotations

import json

import numpy as np

from tlsync_pipeline.sync.model.status import AMBIGUOUS, FAILED, WEAK, Reason, status_of
from tlsync_pipeline.sync.timeline import CameraLine, LogBiasSummary, Timeline, read_timeline, write_timeline


def _line(name: str, **more) -> CameraLine:
    return CameraLine(name, 2.0, 4.0, 400, 380, 0.3, fps=30.0, cov=np.diag([1e-8, 1e-4]), **more)


def test_the_worst_reason_sets_the_status_and_leads():
    reasons = [
        Reason("few_inliers", WEAK, "few", "more"),
        Reason("ambiguous", AMBIGUOUS, "two lines", "init box"),
        Reason("off_path", FAILED, "off", "pose"),
    ]
    status = status_of("cam", reasons)
    assert status.status == FAILED and [r.code for r in status.reasons] == ["off_path", "ambiguous", "few_inliers"]
    assert status.reason == "off" and status.remedy == "pose" and not status.synchronized
    assert status_of("cam", []).status == "ok" and status_of("cam", []).synchronized


def test_flags_warnings_checks_and_failures_become_reasons(tmp_path):
    timeline = Timeline(
        {
            "cam0": _line("cam0"),
            "cam1": _line("cam1", flags=("few_inliers", "clock_disagrees"), warnings=("refinement did not converge",)),
        },
        target_rate=15.0,
        failed={
            "cam2": "camera cam2: the target never comes within eps = 10 px of its projection",
            "cam3": "camera cam3: under this line ...",
        },
        rejected={"cam3": _line("cam3", checks=(Reason("off_path", FAILED, "under this line ...", "check the pose"),))},
    )
    statuses = timeline.statuses()
    assert statuses["cam0"].status == "ok"
    assert statuses["cam1"].status == "weak" and [r.code for r in statuses["cam1"].reasons] == [
        "few_inliers",
        "clock_disagrees",
        "fallback",
    ]
    assert statuses["cam2"].status == "failed" and "pose" in statuses["cam2"].remedy
    assert statuses["cam3"].status == "failed" and statuses["cam3"].reason == "under this line ..."
    write_timeline(timeline, tmp_path / "timeline.json")
    written = json.loads((tmp_path / "timeline.json").read_text())
    assert (
        list(written["cameras"]) == ["cam0", "cam1"]
        and set(written["failed"]) == {"cam2", "cam3"}
        and list(written["rejected"]) == ["cam3"]
    )
    assert {name: entry["status"] for name, entry in written["status"].items()} == {
        "cam0": "ok",
        "cam1": "weak",
        "cam2": "failed",
        "cam3": "failed",
    }
    back = read_timeline(tmp_path / "timeline.json")
    assert {n: s.to_dict() for n, s in back.statuses().items()} == {n: s.to_dict() for n, s in statuses.items()}


def test_a_wide_interval_is_weak():
    wide = Timeline(
        {
            "cam0": _line("cam0"),
            "cam1": CameraLine("cam1", 2.0, 45.0, 400, 30, 0.5, fps=30.0, cov=np.diag([1e-4, 4.0])),
        },
        target_rate=15.0,
    )
    status = wide.status("cam1")
    assert (
        status.status == "weak" and status.reasons[0].code == "wide_interval" and "of its frames only" in status.reason
    )


def test_no_number_that_is_not_finite_reaches_timeline_json(tmp_path):
    timeline = Timeline(
        {"cam0": CameraLine("cam0", 2.0, 4.0, 10, 2, float("nan"), fps=30.0, cov=np.full((2, 2), np.inf))},
        target_rate=15.0,
    )
    write_timeline(timeline, tmp_path / "timeline.json")
    text = (tmp_path / "timeline.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert np.isnan(read_timeline(tmp_path / "timeline.json").cameras["cam0"].residual_rms)


def test_a_slow_target_whose_log_bias_makes_the_start_wide_is_weak_naming_its_speed_even_as_reference(tmp_path):
    slow = LogBiasSummary((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 0.2, speed_m_s=0.4, spread_frames=75.0)
    fast = LogBiasSummary((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 0.2, speed_m_s=6.0, spread_frames=5.0)
    timeline = Timeline({"cam0": _line("cam0", log_bias=slow), "cam1": _line("cam1", log_bias=fast)}, target_rate=15.0)
    status = timeline.status("cam0")
    assert status.status == "weak" and status.reasons[0].code == "low_speed"
    assert "0.4 m/s" in status.reason and "±4.9 s" in status.reason and "at speed" in status.remedy
    assert all(r.code != "low_speed" for r in timeline.status("cam1").reasons)  # fast: the bias is not seconds
    write_timeline(timeline, tmp_path / "timeline.json")
    back = read_timeline(tmp_path / "timeline.json")
    assert back.cameras["cam0"].log_bias == slow and back.status("cam0").to_dict() == status.to_dict()


def test_the_reference_is_weak_when_every_other_cameras_start_against_it_is_wide():
    """The reference's own start is 0 by definition; where every offset it gives is wide (its line alone may make them
    so), it says so too, the narrowest in its own frames; one narrow pair leaves it ok."""
    wide = CameraLine("cam0", 2.0, 4.0, 400, 30, 0.5, fps=30.0, cov=np.diag([1e-8, 4.0]))
    narrow = _line("cam2")
    alone = Timeline({"cam0": wide, "cam1": _line("cam1")}, target_rate=15.0)
    status = alone.status("cam0")
    assert status.status == "weak" and status.reasons[0].code == "wide_interval" and "reference" in status.reason
    assert alone.status("cam1").reasons[0].code == "wide_interval"
    # the narrowest pair's half-width in the reference's frames: cam0's and cam1's beta variances (4 + 1e-4 frames²)
    assert f"±{1.959964 * np.sqrt(4.0 + 1e-4):.1f} of its frames at best" in status.reason
    with_narrow = Timeline({"cam0": _line("cam0"), "cam1": wide, "cam2": narrow}, target_rate=15.0)
    assert with_narrow.status("cam0").status == "ok"
    assert Timeline({"cam0": wide}, target_rate=15.0).status("cam0").status == "ok"  # no offset to give
