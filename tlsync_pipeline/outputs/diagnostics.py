"""What a person checks after a run: the run's warnings (each camera's status is sync/model/status.py's).

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

from tlsync_pipeline.sync.timeline import StageWarning


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


def run_warnings(runs: list[StageRun]) -> list[StageWarning]:
    """The warnings the runs recorded, in the runs' order (pipeline order), each once per task."""
    found: list[StageWarning] = []
    for run in runs:
        found += [StageWarning(run.stage, run.camera, text) for text in dict.fromkeys(run.warnings)]
    return found
