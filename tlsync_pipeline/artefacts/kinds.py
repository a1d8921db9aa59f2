"""Every artefact kind: its path in the work folder, the type of its content, and its reader and writer.

The one table of the work folder's files (docs/pipeline.md lists them for
users, docs/formats.md describes them). Types, readers and writers are given
by name (``module:name``) so that this module imports no implementation: the
engine and every stage use the table, and a stage's code (its cache key, the
import closure of its module) holds only the readers and writers it imports
itself. tests/tlsync_pipeline/artefacts/test_kinds.py resolves every name and
round-trips each reader through its writer.

A reader is ``read(path) -> value``, a writer ``write(value, path)`` (to the
path it is given: a stage passes the temporary file of ``StageFiles.write``).
A kind without a reader is one no stage reads back (exports, pictures, the
report).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Kind:
    """path: relative to the work folder ({camera}: the camera's name); type: ``module:name`` of the content's type;
    reader, writer: ``module:name`` of its functions (None: none); folder: the kind is a folder of files."""

    path: str
    type: str
    reader: str | None = None
    writer: str | None = None
    folder: bool = False


_CAMERA = "calibration.camera"
KINDS: dict[str, Kind] = {
    "intrinsics": Kind("cameras/{camera}/intrinsics.json", f"{_CAMERA}:Camera", f"{_CAMERA}:read_camera", f"{_CAMERA}:write_camera"),
    "intrinsics_report": Kind(
        "cameras/{camera}/intrinsics_report.json",
        "tlsync_pipeline.artefacts.calibration:IntrinsicsReport",
        "tlsync_pipeline.artefacts.calibration:read_intrinsics_report",
        "tlsync_pipeline.artefacts.calibration:write_intrinsics_report",
    ),
    "camera": Kind("cameras/{camera}/camera.json", f"{_CAMERA}:Camera", f"{_CAMERA}:read_camera", f"{_CAMERA}:write_camera"),
    "calibration_report": Kind(
        "cameras/{camera}/calibration_report.json",
        "tlsync_pipeline.artefacts.calibration:CalibrationReport",
        "tlsync_pipeline.artefacts.calibration:read_calibration_report",
        "tlsync_pipeline.artefacts.calibration:write_calibration_report",
    ),
    "calibration_picture": Kind("cameras/{camera}/calibration.png", "builtins:bytes"),
    "track": Kind("cameras/{camera}/track.csv", "trackers.track:Track", "trackers.track:read_track", "trackers.track:write_track"),
    "detections": Kind(
        "cameras/{camera}/detections.csv", "trackers.detections:Detections", "trackers.detections:read_detections", "trackers.detections:write_detections"
    ),
    "scan": Kind(
        "cameras/{camera}/scan.json", "tlsync_pipeline.artefacts.scan:ScanPlan", "tlsync_pipeline.artefacts.scan:read_scan", "tlsync_pipeline.artefacts.scan:write_scan"
    ),
    "identification": Kind(
        "cameras/{camera}/identification.json",
        "tlsync_pipeline.artefacts.identification:IdentificationRecord",
        "tlsync_pipeline.artefacts.identification:read_identification",
        "tlsync_pipeline.artefacts.identification:write_identification",
    ),
    "video_info": Kind(
        "cameras/{camera}/video.json",
        "tlsync_pipeline.artefacts.video_info:VideoInfo",
        "tlsync_pipeline.artefacts.video_info:read_video_info",
        "tlsync_pipeline.artefacts.video_info:write_video_info",
    ),
    "clock": Kind(
        "cameras/{camera}/clock.json",
        "tlsync_pipeline.artefacts.clock:RecordedClock",
        "tlsync_pipeline.artefacts.clock:read_clock",
        "tlsync_pipeline.artefacts.clock:write_clock",
    ),
    "votes": Kind("cameras/{camera}/votes.npz", "tlsync_pipeline.sync.votes:CameraVotes", "tlsync_pipeline.sync.votes:read_votes", "tlsync_pipeline.sync.votes:write_votes"),
    "trajectory": Kind(
        "target/trajectory.csv", "tlsync_pipeline.trajectory:Trajectory", "tlsync_pipeline.trajectory:read_trajectory", "tlsync_pipeline.trajectory:write_trajectory"
    ),
    "ingest_report": Kind(
        "target/ingest_report.json",
        "tlsync_pipeline.ingest.report:IngestReport",
        "tlsync_pipeline.ingest.report:read_ingest_report",
        "tlsync_pipeline.ingest.report:write_ingest_report",
    ),
    "timeline": Kind("timeline.json", "tlsync_pipeline.sync.timeline:Timeline", "tlsync_pipeline.sync.timeline:read_timeline", "tlsync_pipeline.sync.timeline:write_timeline"),
    "frame_map": Kind("exports/frame_map.csv", "builtins:list", writer="tlsync_pipeline.artefacts.exports:write_rows"),
    "offsets": Kind("exports/offsets.csv", "builtins:list", writer="tlsync_pipeline.artefacts.exports:write_offsets"),
    "ffmpeg": Kind("exports/ffmpeg.sh", "builtins:str", writer="tlsync_pipeline.artefacts.exports:write_text"),
    "timeline_otio": Kind("exports/timeline.otio", "builtins:str", writer="tlsync_pipeline.artefacts.exports:write_text"),
    "timeline_fcpxml": Kind("exports/timeline.fcpxml", "builtins:str", writer="tlsync_pipeline.artefacts.exports:write_text"),
    "sync_json": Kind("exports/sync.json", "builtins:dict", writer="tlsync_pipeline.artefacts.jsonfile:write_document"),
    "pictures": Kind("render", "builtins:bytes", folder=True),
    "report_html": Kind("report.html", "builtins:str", writer="tlsync_pipeline.artefacts.exports:write_text"),
    "report": Kind("report.md", "builtins:str", writer="tlsync_pipeline.artefacts.exports:write_text"),
}
FOLDERS = frozenset(name for name, kind in KINDS.items() if kind.folder)


def artefact_path(kind: str, camera: str | None = None) -> str:
    """The path of one artefact relative to the work folder (POSIX)."""
    return KINDS[kind].path.format(camera=camera)
