"""Where each stage's artefacts live in a project's work folder.

    <work>/cameras/<name>/camera.json            calibrate
    <work>/cameras/<name>/calibration_report.json
    <work>/cameras/<name>/calibration.png
    <work>/cameras/<name>/track.csv              track
    <work>/target/trajectory.csv                 ingest
    <work>/target/ingest_report.json
    <work>/timeline.json                         sync
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


def target_dir(work: Path) -> Path:
    return work / "target"


def trajectory_csv(work: Path) -> Path:
    return target_dir(work) / "trajectory.csv"


def ingest_report(work: Path) -> Path:
    return target_dir(work) / "ingest_report.json"


def timeline_json(work: Path) -> Path:
    return work / "timeline.json"
