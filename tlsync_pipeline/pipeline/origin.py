"""The project's ENU origin: a given point, the log's first fix, or the centroid of the cameras' geodetic GCPs.

Shared by the calibrate stage (geodetic GCPs -> local metres) and the ingest
stage (the log -> local metres), so cameras and trajectory share one frame.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibration.extrinsics import read_gcps
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


def origin_inputs(project: Project) -> dict[str, Path]:
    """When the ENU origin is the centroid of every camera's GCPs (no ``[target] origin``, or "gcps"), they are all inputs."""
    if project.target.origin not in (None, "gcps"):
        return {}
    return {f"origin-gcp:{camera.name}": camera.calibration.gcp for camera in project.cameras if camera.calibration.gcp is not None}


def resolve_origin(origin: Origin | str | None, gcp_files: list[Path], where: str) -> Origin | str:
    """The ENU origin shared by geodetic GCPs and the target's log (ingest uses this too).

    ``origin = [lat, lon, alt]``: that point. ``"gcps"``, or unset while some
    of ``gcp_files`` is geodetic: the centroid (mean latitude, longitude,
    height) of their geodetic points. ``"first"``, or unset without geodetic
    GCPs: the string "first" (the log's first fix, known to ingest only).
    """
    if isinstance(origin, Origin) or origin == "first":
        return origin
    points = [table.geodetic for table in map(read_gcps, gcp_files) if table.geodetic is not None]
    if not points:
        if origin == "gcps":
            raise InputError(f'{where}: origin = "gcps" but no camera has geodetic (lat,lon,alt) ground control points')
        return "first"
    lat, lon, alt = np.concatenate(points).mean(axis=0)
    return Origin(float(lat), float(lon), float(alt))


def project_origin(project: Project) -> Origin | str:
    """The project's ENU origin (resolve_origin over every camera's GCP file)."""
    return resolve_origin(project.target.origin, list(origin_inputs(project).values()), f"{project.path}: [target]")
