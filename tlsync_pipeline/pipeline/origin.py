"""The project's ENU origin: a given point, the log's first fix, or the centroid of the cameras' geodetic GCPs.

Shared by the calibrate stage (geodetic GCPs -> local metres) and the ingest
stage (the log -> local metres), so cameras and trajectory share one frame.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import FAR_M, Origin, heights_in_feet, horizontal_distance, likely_slip, median_point

if TYPE_CHECKING:
    from calibration.extrinsics import GcpTable
    from tlsync_pipeline.pipeline.project import Project


def origin_inputs(project: Project) -> dict[str, Path]:
    """When the ENU origin is the centroid of every camera's GCPs (no ``[target] origin``, or "gcps"), they are all
    inputs.
    """
    if project.target.origin not in (None, "gcps"):
        return {}
    return {
        f"origin-gcp:{camera.name}": camera.calibration.gcp
        for camera in project.cameras
        if camera.calibration.gcp is not None
    }


def resolve_origin(origin: Origin | str | None, gcp_files: list[Path], where: str) -> Origin | str:
    """The ENU origin shared by geodetic GCPs and the target's log (ingest uses this too).

    ``origin = [lat, lon, alt]``: that point. ``"gcps"``, or unset while some
    of ``gcp_files`` is geodetic: the centroid (mean latitude, longitude,
    height) of their geodetic points. ``"first"``, or unset without geodetic
    GCPs: the string "first" (the log's first fix, known to ingest only).
    """
    if isinstance(origin, Origin) or origin == "first":
        return origin
    from calibration.extrinsics import read_gcps  # OpenCV loads only where GCP files are read

    tables = [table for table in map(read_gcps, gcp_files) if table.geodetic is not None]
    if not tables:
        if origin == "gcps":
            raise InputError(f'{where}: origin = "gcps" but no camera has geodetic (lat,lon,alt) ground control points')
        return "first"
    for table in tables:
        check_gcp_places(table)
    _check_files_together(tables)
    lat, lon, alt = np.concatenate([table.geodetic for table in tables if table.geodetic is not None]).mean(axis=0)
    return Origin(float(lat), float(lon), float(alt))


def check_gcp_places(table: GcpTable, origin: Origin | None = None, origin_label: str = "the [target] origin") -> None:
    """InputError naming the likely slip (latitude and longitude swapped, a sign, feet) when a table's geodetic
    points lie more than FAR_M from each other or from ``origin``."""
    if table.geodetic is None:
        return
    lat, lon, alt = table.geodetic.T
    centre = median_point(lat, lon, alt)
    apart = horizontal_distance(lat, lon, centre)
    odd = np.flatnonzero(apart > FAR_M)
    if len(odd):
        i = int(odd[0])
        cause = likely_slip(lat[odd], lon[odd], centre) or "check its lat and lon (WGS84 degrees)"
        point = "the point" if table.names[i] == f"line {table.lines[i]}" else f"point {table.names[i]}"
        raise InputError(
            f"{table.source}:{table.lines[i]}: {point} is {apart[i] / 1000:,.0f} km from the file's other points; "
            f"{cause}"
        )
    if origin is None:
        return
    far = float(np.median(horizontal_distance(lat, lon, origin)))
    if far > FAR_M:
        cause = likely_slip(lat, lon, origin) or f"check the lat and lon columns (WGS84 degrees) and {origin_label}"
        raise InputError(f"{table.source}: the points are {far / 1000:,.0f} km from {origin_label}; {cause}")
    if heights_in_feet(alt, origin):
        raise InputError(
            f"{table.source}: the heights are {np.median(alt) - origin.alt:+.0f} m from {origin_label}'s; in feet "
            f"they would match it: give alt in metres"
        )


def _check_files_together(tables: list[GcpTable]) -> None:
    """InputError when one camera's geodetic GCPs lie more than FAR_M from the other cameras': the file and the likely
    slip.

    The reference is the median of every file's median point, which one
    wrong file does not move when there are three or more; of two files
    far apart, geometry cannot tell which one slipped.
    """
    if len(tables) < 2:
        return
    centres = [median_point(*table.geodetic.T) for table in tables if table.geodetic is not None]
    near = median_point([c.lat for c in centres], [c.lon for c in centres], [c.alt for c in centres])
    if len(tables) == 2:
        far = float(horizontal_distance([centres[0].lat], [centres[0].lon], centres[1])[0])
        if far > FAR_M:
            geo = tables[0].geodetic
            assert geo is not None
            cause = likely_slip(geo[:, 0], geo[:, 1], centres[1])
            raise InputError(
                f"{tables[0].source}, {tables[1].source}: the two cameras' GCPs are {far / 1000:,.0f} km apart; "
                + (f"in one of them {cause}" if cause else "check their lat and lon (WGS84 degrees)")
            )
        return
    for table, centre in zip(tables, centres):
        far = float(horizontal_distance([centre.lat], [centre.lon], near)[0])
        if far > FAR_M:
            assert table.geodetic is not None
            cause = (
                likely_slip(table.geodetic[:, 0], table.geodetic[:, 1], near) or "check its lat and lon (WGS84 degrees)"
            )
            raise InputError(
                f"{table.source}: its points are {far / 1000:,.0f} km from the other cameras' GCPs; {cause}"
            )


def check_log_near_gcps(log_centre: Origin, log: Path, gcp_files: list[Path], origin: Origin) -> None:
    """InputError when the target's log lies more than FAR_M from the origin the cameras' GCPs give (their centroid):
    the GCP file whose likely slip (latitude and longitude swapped, a sign) explains it, or the log."""
    far = float(horizontal_distance([log_centre.lat], [log_centre.lon], origin)[0])
    if far <= FAR_M:
        return
    from calibration.extrinsics import read_gcps

    for table in map(read_gcps, gcp_files):
        if table.geodetic is not None and (
            cause := likely_slip(table.geodetic[:, 0], table.geodetic[:, 1], log_centre)
        ):
            raise InputError(
                f"{table.source}: the GCPs are {far / 1000:,.0f} km from the target's log ({log.name}); {cause}"
            )
    raise InputError(
        f"{log}: the log is {far / 1000:,.0f} km from the cameras' GCPs (their centroid is the origin); check the "
        f"log's positions and the GCP files' lat and lon"
    )


def project_origin(project: Project) -> Origin | str:
    """The project's ENU origin (resolve_origin over every camera's GCP file)."""
    return resolve_origin(project.target.origin, list(origin_inputs(project).values()), f"{project.path}: [target]")
