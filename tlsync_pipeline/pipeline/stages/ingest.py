"""The ingest stage's file edge: project keys to parameters, log to artefacts.

Artefacts: the trajectory CSV (``t,x,y,z``, t in POSIX seconds for GPS logs,
so read_trajectory recovers rate and t0) and the report JSON (origin, rate,
t0, gaps, drops), both written atomically.
"""

from __future__ import annotations

import json
from pathlib import Path

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest import read_log
from tlsync_pipeline.ingest.process import (
    IngestParams,
    IngestReport,
    RigidTransform,
    ingest,
)
from tlsync_pipeline.pipeline import layout
from tlsync_pipeline.pipeline.project import Project
from tlsync_pipeline.pipeline.stages.calibrate import project_origin
from tlsync_pipeline.trajectory import Trajectory, write_trajectory


def ingest_log(path: str | Path, fmt: str = "auto", params: IngestParams = IngestParams(), topic: str | None = None) -> tuple[Trajectory, IngestReport]:
    """Read and ingest one log."""
    return ingest(read_log(path, fmt, topic), params)


def write_ingest(trajectory: Trajectory, report: IngestReport, csv_path: Path, report_path: Path) -> None:
    """Write the trajectory CSV and the report JSON, each atomically."""
    with atomic_path(csv_path) as tmp:
        write_trajectory(trajectory, tmp)
    with atomic_path(report_path) as tmp:
        tmp.write_text(json.dumps(report.to_dict(), indent=1) + "\n", encoding="utf-8")


def report_sidecar(csv_path: Path) -> Path:
    """Where ``tlsync ingest-log`` puts the report: beside the CSV, ``<stem>.ingest.json``."""
    return csv_path.with_name(csv_path.stem + ".ingest.json")


def target_params(project: Project) -> IngestParams:
    """IngestParams from the project's [target] table; the origin follows calibrate.project_origin."""
    target = project.target
    origin = project_origin(project)
    transform = target["odometry_transform"]
    return IngestParams(
        origin=origin,
        rate=target["rate"],
        max_gap_s=target["max_gap_s"],
        max_speed_mps=target["max_speed_mps"],
        smoothing_s=target["smoothing_s"],
        transform=transform,
    )


def ingest_project(project: Project, work: Path) -> IngestReport:
    """Ingest the project's [target] log into the work folder's target/ artefacts."""
    target = project.target
    if target["log"] is None:
        hint = " (its 'trajectory' is already a metric trajectory: nothing to ingest)" if target["trajectory"] is not None else ""
        raise InputError(f"{project.path}: [target]: no 'log' to ingest{hint}")
    trajectory, report = ingest_log(target["log"], target["format"], target_params(project), target["topic"])
    write_ingest(trajectory, report, layout.trajectory_csv(work), layout.ingest_report(work))
    return report


def parse_origin(text: str) -> Origin | str:
    """``LAT,LON,ALT`` (degrees, degrees, metres) or ``first``, for the command line."""
    if text.strip().lower() == "first":
        return "first"
    try:
        lat, lon, alt = (float(v) for v in text.split(","))
        return Origin(lat, lon, alt)
    except ValueError as exc:
        raise InputError(f"--origin {text!r}: expected LAT,LON,ALT (degrees, degrees, metres) or 'first' ({exc})") from None


__all__ = ["RigidTransform", "ingest_log", "ingest_project", "parse_origin", "report_sidecar", "target_params", "write_ingest"]


def run_ingest(project: Project, work: Path) -> dict:
    """The ingest stage: the target's log into ``target/trajectory.csv`` and its report."""
    report = ingest_project(project, work)
    return {"message": report.summary(with_warnings=False), "warnings": list(report.warnings)}
