"""The clock stage: when a camera's video was recorded by its own clock, into ``cameras/<name>/clock.json``.

``[cameras.clock] recorded``: "metadata" reads the video (and a DJI subtitle
file beside it) with tlsync_pipeline.ingest.recording_time and keeps the
first trusted source, or with ``tolerance_s`` the first of any; an ISO 8601
time with its zone is the user's own (tolerance ``tolerance_s``, default
1 s); "off" skips the stage. clock.json holds ``utc_s``, ``tolerance_s`` and
``source``, or ``none`` with the reason; the sync stage checks each camera's
line against it (tlsync_pipeline.sync.clock_prior).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from tlsync_pipeline.artefacts.clock import ClockPrior, RecordedClock, write_clock
from tlsync_pipeline.ingest.recording_time import PHONE_TOLERANCE_S, RecordingTime, choose, parse_utc, recording_time
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

GIVEN_TOLERANCE_S = PHONE_TOLERANCE_S  # a time the user gives, without a tolerance


@dataclass(frozen=True)
class ClockStageParams:
    """recorded: "metadata" or an ISO 8601 time with its zone; tolerance_s: the project's (None: the source's);
    utc_offset: local - UTC (s) of a DJI subtitle file beside the video."""

    recorded: str
    tolerance_s: float | None
    utc_offset: float | None


def run_clock(files: StageFiles, params: ClockStageParams) -> StageResult:
    """The clock stage: the camera's recording time (or why there is none) into clock.json."""
    if params.recorded == "metadata":
        found = choose(recording_time(files.path("video"), params.utc_offset), params.tolerance_s)
    else:
        utc = parse_utc(params.recorded)
        assert utc is not None, "checked by the project"
        found = RecordingTime(
            utc, params.tolerance_s or GIVEN_TOLERANCE_S, "the project ([cameras.clock] recorded)", True
        )
    if isinstance(found, str):
        record = RecordedClock(None, found)
        message = f"camera {files.camera}: no clock to check against: {found}"
    else:
        assert found.tolerance_s is not None, "choose and a given time both set the tolerance"
        prior = ClockPrior(found.utc_s, found.tolerance_s, found.source)
        record = RecordedClock(prior)
        message = f"camera {files.camera}: recorded at {prior.utc} +- {found.tolerance_s:g} s by {found.source}"
    with files.write("clock") as tmp:
        write_clock(record, tmp)
    return StageResult(message)


def clock_inputs(src: Sources, cam: str) -> dict[str, Path | Artefact]:
    """The video, and a DJI subtitle file beside it, when the recording time is read from metadata."""
    camera = src.project.camera(cam)
    if camera.clock.recorded != "metadata" or camera.video is None:
        return {}
    inputs: dict[str, Path | Artefact] = {"video": camera.video}
    for suffix in (".SRT", ".srt"):
        if camera.video.with_suffix(suffix).exists():
            inputs["subtitles"] = camera.video.with_suffix(suffix)
            break
    return inputs


def clock_params(project: Project, cam: str, options: Options) -> ClockStageParams:
    clock = project.camera(cam).clock
    return ClockStageParams(clock.recorded, clock.tolerance_s, clock.utc_offset)


def _applies(project: Project, cam: str) -> bool:
    camera = project.camera(cam)
    return camera.clock.recorded != "off" and (camera.clock.recorded != "metadata" or camera.video is not None)


SPEC = StageSpec(
    "clock",
    inputs=clock_inputs,
    params=clock_params,
    outputs=("clock",),
    run=run_clock,
    per_camera=True,
    light=True,
    applies=_applies,
)
