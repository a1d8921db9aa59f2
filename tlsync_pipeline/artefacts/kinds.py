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


def _typed(path: str, module: str, type_name: str, name: str) -> Kind:
    """A kind whose type and functions ``read_<name>``, ``write_<name>`` are in ``module``."""
    return Kind(path, f"{module}:{type_name}", f"{module}:read_{name}", f"{module}:write_{name}")


_ARTEFACTS = "tlsync_pipeline.artefacts"
_EXPORTS = "tlsync_pipeline.artefacts.exports"
KINDS: dict[str, Kind] = {
    "intrinsics": _typed("cameras/{camera}/intrinsics.json", "calibration.camera", "Camera", "camera"),
    "intrinsics_report": _typed(
        "cameras/{camera}/intrinsics_report.json", f"{_ARTEFACTS}.calibration", "IntrinsicsReport", "intrinsics_report"
    ),
    "camera": _typed("cameras/{camera}/camera.json", "calibration.camera", "Camera", "camera"),
    "calibration_report": _typed(
        "cameras/{camera}/calibration_report.json",
        f"{_ARTEFACTS}.calibration",
        "CalibrationReport",
        "calibration_report",
    ),
    "calibration_picture": Kind("cameras/{camera}/calibration.png", "builtins:bytes"),
    "track": _typed("cameras/{camera}/track.csv", "trackers.track", "Track", "track"),
    "detections": _typed("cameras/{camera}/detections.csv", "trackers.detections", "Detections", "detections"),
    "scan": _typed("cameras/{camera}/scan.json", f"{_ARTEFACTS}.scan", "ScanPlan", "scan"),
    "background": _typed("cameras/{camera}/background.npy", "trackers.background", "Background", "background"),
    "identification": _typed(
        "cameras/{camera}/identification.json", f"{_ARTEFACTS}.identification", "IdentificationRecord", "identification"
    ),
    "video_info": _typed("cameras/{camera}/video.json", f"{_ARTEFACTS}.video_info", "VideoInfo", "video_info"),
    "clock": _typed("cameras/{camera}/clock.json", f"{_ARTEFACTS}.clock", "RecordedClock", "clock"),
    "votes": _typed("cameras/{camera}/votes.npz", "tlsync_pipeline.sync.vote.votes", "CameraVotes", "votes"),
    "trajectory": _typed("target/trajectory.csv", "tlsync_pipeline.trajectory", "Trajectory", "trajectory"),
    "ingest_report": _typed(
        "target/ingest_report.json", "tlsync_pipeline.ingest.report", "IngestReport", "ingest_report"
    ),
    "timeline": _typed("timeline.json", "tlsync_pipeline.sync.timeline", "Timeline", "timeline"),
    "frame_map": Kind("exports/frame_map.csv", "builtins:list", writer=f"{_EXPORTS}:write_rows"),
    "offsets": Kind("exports/offsets.csv", "builtins:list", writer=f"{_EXPORTS}:write_offsets"),
    "ffmpeg": Kind("exports/ffmpeg.sh", "builtins:str", writer=f"{_EXPORTS}:write_text"),
    "timeline_otio": Kind("exports/timeline.otio", "builtins:str", writer=f"{_EXPORTS}:write_text"),
    "timeline_fcpxml": Kind("exports/timeline.fcpxml", "builtins:str", writer=f"{_EXPORTS}:write_text"),
    "sync_json": Kind("exports/sync.json", "builtins:dict", writer=f"{_ARTEFACTS}.jsonfile:write_document"),
    "pictures": Kind("render", "builtins:bytes", folder=True),
    "report_html": Kind("report.html", "builtins:str", writer=f"{_EXPORTS}:write_text"),
    "report": Kind("report.md", "builtins:str", writer=f"{_EXPORTS}:write_text"),
}
FOLDERS = frozenset(name for name, kind in KINDS.items() if kind.folder)


def artefact_path(kind: str, camera: str | None = None) -> str:
    """The path of one artefact relative to the work folder (POSIX)."""
    return KINDS[kind].path.format(camera=camera)
