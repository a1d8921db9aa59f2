"""What a person checks after a run: each camera's status and the run's warnings.

Each stage returns its warnings (StageResult.warnings: rejected checkerboard
views from intrinsics, GCP outliers and a missing pose from calibrate, a
truncated video from track, the log reader's from ingest, a sync method's
per camera); the engine records them in the stage's manifest. The run's
list is those records, in pipeline order, each once: the terminal,
timeline.json and report.html show that one list. Export and render, which
come after the timeline, say what they could not write in their messages.

Pure functions of the parsed files.
"""

from __future__ import annotations

from dataclasses import dataclass

from tlsync_pipeline.sync.timeline import StageWarning, Timeline

HALF_95 = 1.959964  # normal quantile of a two-sided 95 % interval

FLAG_MEANING = {
    "few_inliers": "few frames support the line",
    "ambiguous": "a second line has comparable support",
    "along_ray": "the target moves mostly along the viewing ray",
    "clock_disagrees": "the offset disagrees with the camera's own clock by more than its tolerance (see clock_prior)",
}


@dataclass(frozen=True)
class StageRun:
    """One stage's last run, from its manifest: stage, camera (None: the project), when (UTC), seconds, its warnings
    and its message (what it wrote, what it could not)."""

    stage: str
    camera: str | None
    created: str
    seconds: float | None
    warnings: tuple[str, ...] = ()
    message: str | None = None


@dataclass(frozen=True)
class CameraStatus:
    """ok, weak or failed, and why, in words."""

    camera: str
    status: str
    reason: str


def run_warnings(runs: list[StageRun]) -> list[StageWarning]:
    """The warnings the runs recorded, in the runs' order (pipeline order), each once per task."""
    found: list[StageWarning] = []
    for run in runs:
        found += [StageWarning(run.stage, run.camera, text) for text in dict.fromkeys(run.warnings)]
    return found


# What dominates a camera's interval (timeline.ErrorBudget.dominant), and what to do about it.
DOMINANT_CAUSE = {
    "log": "the log's bias dominates: walk a curved path through this view, or use an RTK log",
    "calibration": "calibration or pose dominates: add or check ground control points, or check the camera's calibration",
    "tracking": "tracking dominates: a longer or closer pass through the view, or a sharper video",
}


def camera_status(timeline: Timeline, name: str) -> CameraStatus:
    """failed (not synchronized), weak (flags, a fallback, or a start interval wider than one of its frames) or ok."""
    if name in timeline.failed:
        return CameraStatus(name, "failed", timeline.failed[name])
    line = timeline.cameras[name]
    support = f"{line.inliers} of {line.votes} votes on the line"
    reasons = [FLAG_MEANING.get(flag, flag) for flag in line.flags or ()]
    if line.warnings:
        reasons.append("the refinement was not used (see warnings)")
    reference = timeline.names[0]
    se = timeline.start_offset_se(reference, name) if name != reference else None
    if se is not None:
        own_frames = HALF_95 * (se[1] * line.fps if se[1] is not None and line.fps else se[0])
        if own_frames > 1.0:
            seconds = "" if se[1] is None else f"±{HALF_95 * se[1]:.2g} s, "
            cause = f": {DOMINANT_CAUSE[line.budget.dominant]}" if line.budget is not None and line.budget.total_frames > 0 else ""
            reasons.append(f"start known to {seconds}±{own_frames:.1f} of its frames only{cause}")
    if reasons:
        return CameraStatus(name, "weak", "; ".join(reasons) + f" ({support})")
    return CameraStatus(name, "ok", support)


def all_statuses(timeline: Timeline) -> list[CameraStatus]:
    """Every synchronized camera's status, then the failed ones."""
    return [camera_status(timeline, name) for name in list(timeline.cameras) + list(timeline.failed)]
