"""The ingest stage's file edge: project keys to parameters, log to artefacts.

Artefacts: the trajectory CSV (``t,x,y,z``, t in POSIX seconds for GPS logs,
so read_trajectory recovers rate and t0) and the report JSON (origin, rate,
t0, gaps, drops), both written atomically.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, enu_to_geodetic
from tlsync_pipeline.ingest.params import IngestParams, RigidTransform
from tlsync_pipeline.ingest.process import ingest
from tlsync_pipeline.ingest.read import read_log
from tlsync_pipeline.ingest.recording_time import parse_utc_offset
from tlsync_pipeline.ingest.report import IngestReport, write_ingest_report
from tlsync_pipeline.ingest.units import implausible_motion
from tlsync_pipeline.pipeline.origin import check_log_near_gcps, origin_inputs, resolve_origin
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.trajectory import Trajectory, read_trajectory, trajectory_from_times, write_trajectory

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project, TargetConfig


def ingest_log(
    path: str | Path,
    fmt: str = "auto",
    params: IngestParams = IngestParams(),
    topic: str | None = None,
    utc_offset_s: float | None = None,
) -> tuple[Trajectory, IngestReport]:
    """Read and ingest one log (utc_offset_s: local - UTC of a log whose clock is local)."""
    return ingest(read_log(path, fmt, topic, utc_offset_s), params)


def write_ingest(trajectory: Trajectory, report: IngestReport, csv_path: Path, report_path: Path) -> None:
    """Write the trajectory CSV and the report JSON, each atomically."""
    with atomic_path(csv_path) as tmp:
        write_trajectory(trajectory, tmp)
    with atomic_path(report_path) as tmp:
        write_ingest_report(report, tmp)


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
        raise InputError(
            f"--origin {text!r}: expected LAT,LON,ALT (degrees, degrees, metres) or 'first' ({exc})"
        ) from None


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
    """The ingest stage: the target's log (or a trajectory the project brings in other units than seconds and
    metres) into ``target/trajectory.csv`` and its report.

    ``target``: the project's [target] without its files (log, trajectory: inputs).
    """
    if files.has("given"):
        trajectory, report = convert_trajectory(files.path("given"), target.time_unit, target.length_unit)
    else:
        gcp_files = [files.path(label) for label in files.inputs if label.startswith("origin-gcp:")]
        origin = resolve_origin(target.origin, gcp_files, "[target]")
        trajectory, report = ingest_log(
            files.path("log"), target.format, target.ingest_params(origin), target.topic, target.utc_offset
        )
        problem = implausible_motion(np.asarray(trajectory.seconds(trajectory.sample)), trajectory.xyz)
        if problem:
            raise InputError(f"{files.path('log')} ([target] log): {problem}")
        if isinstance(origin, Origin) and not isinstance(target.origin, Origin) and len(trajectory):
            lat, lon, alt = enu_to_geodetic(np.median(trajectory.xyz, axis=0), origin)[0]
            check_log_near_gcps(Origin(lat, lon, alt), files.path("log"), gcp_files, origin)
    write_ingest(trajectory, report, files.output("trajectory"), files.output("ingest_report"))
    return StageResult(report.summary(with_warnings=False), tuple(report.warnings))


def convert_trajectory(path: Path, time_unit: float, length_unit: float) -> tuple[Trajectory, IngestReport]:
    """A trajectory CSV whose times are in units of ``time_unit`` seconds and positions of ``length_unit`` metres, in
    seconds and metres, and its report.
    """
    given = read_trajectory(path)
    t = given.seconds(given.sample)
    xyz = given.xyz * length_unit
    if t is None:
        trajectory = Trajectory(given.sample, xyz, sigma=given.sigma)
    else:
        trajectory = trajectory_from_times(np.asarray(t) * time_unit, xyz, sigma=given.sigma)
    extent = (xyz.max(axis=0) - xyz.min(axis=0)).round(3).tolist()
    rate = trajectory.rate or 1.0
    report = IngestReport(
        source=str(path),
        format="trajectory",
        frame="local",
        fixes_read=len(given),
        fixes_used=len(given),
        samples=len(trajectory),
        rate=float(rate),
        t0=float(trajectory.t0 or 0.0),
        t0_utc=None,
        duration_s=float((trajectory.sample[-1] - trajectory.sample[0]) / rate),
        extent_m=extent,
        max_gap_s=0.0,
        gaps=[],
        grid_left_out=0,
        dropped={},
        unit="line",
        ignored=0,
        origin=None,
        params={"time_unit": time_unit, "length_unit": length_unit},
        clock="the trajectory's own clock",
    )
    return trajectory, report


def ingest_inputs(src: Sources, camera: None) -> dict[str, Path | Artefact]:
    """The log and the origin's GCP files; or the trajectory to convert to seconds and metres."""
    target = src.project.target
    if target.trajectory is not None:
        assert target.converts_trajectory, "the stage applies"
        return {"given": target.trajectory}
    assert target.log is not None, "the stage applies to a project with a log"
    return {"log": target.log, **origin_inputs(src.project)}


# The [target] keys the ingest stage reads: of a log (how it is read, its origin, IngestParams'), of a trajectory it
# converts.
LOG_KEYS = (
    "origin",
    "format",
    "topic",
    "utc_offset",
    "rate",
    "max_gap_s",
    "max_speed_mps",
    "smoothing_s",
    "odometry_transform",
    "altitude_reference",
    "altitude_offset_m",
    "time_unit",
    "length_unit",
)
UNIT_KEYS = ("time_unit", "length_unit")


def ingest_params(project: Project, cam: None, options: Options) -> TargetConfig:
    """[target] with the keys the stage reads and every other at its default (its files are inputs; the log's error
    model is vote's and sync's), so that a key it does not read leaves it fresh."""
    target = project.target
    kept = UNIT_KEYS if target.trajectory is not None else LOG_KEYS
    return dataclasses.replace(
        target, **{f.name: _default(f) for f in dataclasses.fields(target) if f.name not in kept}
    )


def _default(key: dataclasses.Field):
    return key.default_factory() if key.default_factory is not dataclasses.MISSING else key.default


SPEC = StageSpec(
    "ingest",
    inputs=ingest_inputs,
    params=ingest_params,
    outputs=("trajectory", "ingest_report"),
    run=run_ingest,
    applies=lambda project, cam: (
        project.target.converts_trajectory or (project.target.trajectory is None and project.target.log is not None)
    ),
)
