"""Where each stage's artefacts live in a project's work folder.

    <work>/cameras/<name>/camera.json            calibrate
    <work>/cameras/<name>/calibration_report.json
    <work>/cameras/<name>/calibration.png
    <work>/cameras/<name>/track.csv              track
    <work>/cameras/<name>/video.json             track (frames decoded, truncation)
    <work>/cameras/<name>/votes.npz              vote
    <work>/target/trajectory.csv                 ingest
    <work>/target/ingest_report.json
    <work>/timeline.json                         sync
    <work>/exports/frame_map.csv                 export
    <work>/exports/offsets.csv
    <work>/exports/ffmpeg.sh
    <work>/render/*.png                          render
    <work>/report.md
    <dir>/<stage>.manifest.json                  beside each stage's artefacts (cache)
    <work>/.lock                                 held by the running tlsync
    <work>/.hashes.json                          remembered file hashes
"""

from __future__ import annotations

from pathlib import Path


def camera_dir(work: Path, name: str) -> Path:
    return work / "cameras" / name


def camera_json(work: Path, name: str) -> Path:
    return camera_dir(work, name) / "camera.json"


def calibration_report(work: Path, name: str) -> Path:
    return camera_dir(work, name) / "calibration_report.json"


def calibration_picture(work: Path, name: str) -> Path:
    return camera_dir(work, name) / "calibration.png"


def track_csv(work: Path, name: str) -> Path:
    return camera_dir(work, name) / "track.csv"


def video_info(work: Path, name: str) -> Path:
    return camera_dir(work, name) / "video.json"


def target_dir(work: Path) -> Path:
    return work / "target"


def trajectory_csv(work: Path) -> Path:
    return target_dir(work) / "trajectory.csv"


def ingest_report(work: Path) -> Path:
    return target_dir(work) / "ingest_report.json"


def timeline_json(work: Path) -> Path:
    return work / "timeline.json"


def votes_npz(work: Path, name: str) -> Path:
    return camera_dir(work, name) / "votes.npz"


def exports_dir(work: Path) -> Path:
    return work / "exports"


def frame_map_csv(work: Path) -> Path:
    return exports_dir(work) / "frame_map.csv"


def offsets_csv(work: Path) -> Path:
    return exports_dir(work) / "offsets.csv"


def ffmpeg_script(work: Path) -> Path:
    return exports_dir(work) / "ffmpeg.sh"


def render_dir(work: Path) -> Path:
    return work / "render"


def report_md(work: Path) -> Path:
    return work / "report.md"


_GLOBAL_STAGE_DIRS = {"ingest": target_dir, "export": exports_dir, "render": render_dir}


def manifest_json(work: Path, stage: str, name: str | None) -> Path:
    """The manifest of one stage run, beside its artefacts (a camera's, or the global one when name is None)."""
    if name is not None:
        return camera_dir(work, name) / f"{stage}.manifest.json"
    folder = _GLOBAL_STAGE_DIRS.get(stage, lambda w: w)(work)
    return folder / f"{stage}.manifest.json"


def hash_memo(work: Path) -> Path:
    return work / ".hashes.json"
