"""The ingest stage's file edge: project keys to parameters, log to artefacts.

Artefacts: the trajectory CSV (``t,x,y,z``, t in POSIX seconds for GPS logs,
so read_trajectory recovers rate and t0) and the report JSON (origin, rate,
t0, gaps, drops), both written atomically.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, enu_to_geodetic
from tlsync_pipeline.ingest import read_log
from tlsync_pipeline.ingest.recording_time import parse_utc_offset
from tlsync_pipeline.ingest.process import (
    IngestParams,
    IngestReport,
    RigidTransform,
    ingest,
)
from tlsync_pipeline.pipeline.origin import check_log_near_gcps, origin_inputs, resolve_origin
from tlsync_pipeline.pipeline.spec import Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.trajectory import Trajectory, write_trajectory

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import TargetConfig


def ingest_log(path: str | Path, fmt: str = "auto", params: IngestParams = IngestParams(), topic: str | None = None,
               utc_offset_s: float | None = None) -> tuple[Trajectory, IngestReport]:
    """Read and ingest one log (utc_offset_s: local - UTC of a log whose clock is local)."""
    return ingest(read_log(path, fmt, topic, utc_offset_s), params)


def write_ingest(trajectory: Trajectory, report: IngestReport, csv_path: Path, report_path: Path) -> None:
    """Write the trajectory CSV and the report JSON, each atomically."""
    with atomic_path(csv_path) as tmp:
        write_trajectory(trajectory, tmp)
    with atomic_path(report_path) as tmp:
        tmp.write_text(json.dumps(report.to_dict(), indent=1) + "\n", encoding="utf-8")


def report_sidecar(csv_path: Path) -> Path:
    """Where ``tlsync ingest-log`` puts the report: beside the CSV, ``<stem>.ingest.json``."""
    return csv_path.with_name(csv_path.stem + ".ingest.json")


def parse_origin(text: str) -> Origin | str:
    """``LAT,LON,ALT`` (degrees, degrees, metres) or ``first``, for the command line."""
    if text.strip().lower() == "first":
        return "first"
    try:
        lat, lon, alt = (float(v) for v in text.split(","))
        return Origin(lat, lon, alt)
    except ValueError as exc:
        raise InputError(f"--origin {text!r}: expected LAT,LON,ALT (degrees, degrees, metres) or 'first' ({exc})") from None


def parse_utc_offset_option(text: str) -> float:
    """--utc-offset: hours (``2``, ``-3.5``) or ``+HH:MM``, to seconds (local - UTC)."""
    try:
        value: float | str = float(text)
    except ValueError:
        value = text
    try:
        return parse_utc_offset(value)
    except ValueError as exc:
        raise InputError(f"--utc-offset {text!r}: {exc}") from None


__all__ = ["RigidTransform", "ingest_log", "parse_origin", "parse_utc_offset_option", "report_sidecar", "write_ingest"]


def run_ingest(files: StageFiles, target: TargetConfig) -> StageResult:
    """The ingest stage: the target's log into ``target/trajectory.csv`` and its report.

    ``target``: the project's [target] without its files (log, trajectory: inputs).
    """
    gcp_files = [files.path(label) for label in files.inputs if label.startswith("origin-gcp:")]
    origin = resolve_origin(target.origin, gcp_files, "[target]")
    trajectory, report = ingest_log(files.path("log"), target.format, target.ingest_params(origin), target.topic, target.utc_offset)
    if isinstance(origin, Origin) and not isinstance(target.origin, Origin) and len(trajectory):
        lat, lon, alt = enu_to_geodetic(np.median(trajectory.xyz, axis=0), origin)[0]
        check_log_near_gcps(Origin(lat, lon, alt), files.path("log"), gcp_files, origin)
    write_ingest(trajectory, report, files.output("trajectory"), files.output("ingest_report"))
    return StageResult(report.summary(with_warnings=False), tuple(report.warnings))


def ingest_inputs(src: Sources, camera: None) -> dict[str, Path | Artefact]:
    """The log, and the GCP files when the ENU origin is their centroid."""
    assert src.project.target.log is not None, "the stage applies to a project with a log"
    return {"log": src.project.target.log, **origin_inputs(src.project)}


SPEC = StageSpec(
    "ingest",
    inputs=ingest_inputs,
    params=lambda project, cam, options: dataclasses.replace(project.target, log=None, trajectory=None),
    outputs=("trajectory", "ingest_report"),
    run=run_ingest,
    applies=lambda project, cam: project.target.trajectory is None and project.target.log is not None,
)
