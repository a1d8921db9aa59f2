"""Camera pose (extrinsics) from ground control points or from a board at a known pose.

World points are local metres (the trajectory's frame; geodetic points are
converted by the pipeline before they get here). The pose is world -> camera:
X_cam = R @ X_world + t. Pixels have their origin at the centre of the
top-left pixel and are distorted (as clicked in a frame).

GCP CSV: a header, then one row per point, columns ``u,v,x,y,z`` (local
metres) or ``u,v,lat,lon,alt`` (WGS84 degrees, degrees, metres above the
ellipsoid), optionally ``name``; ``#`` starts a comment line.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from calibration.choices import RANSAC_PX
from calibration.errors import CalibrationInputError, read_text
from calibration.intrinsics import Pattern
from calibration.lens import project_points, undistort_pixels

MIN_POINTS = 4
RANSAC_MIN_POINTS = 6
LOCAL_COLUMNS = ("u", "v", "x", "y", "z")
GEODETIC_COLUMNS = ("u", "v", "lat", "lon", "alt")


@dataclass(frozen=True)
class GcpTable:
    """Ground control points of one camera: pixels (N, 2) and either local ``xyz`` (N, 3) or ``geodetic`` lat/lon/alt
    (N, 3).
    """

    source: str
    uv: np.ndarray
    xyz: np.ndarray | None
    geodetic: np.ndarray | None
    names: tuple[str, ...]
    lines: tuple[int, ...]  # 1-based line of each point in the file


def read_gcps(path: str | Path) -> GcpTable:
    """Read a GCP CSV (see the module doc); errors name the file, line and column."""
    path = Path(path)
    text = read_text(path, "utf-8-sig")
    rows = [
        (n, row)
        for n, row in enumerate(csv.reader(text.splitlines()), start=1)
        if row and not row[0].lstrip().startswith("#") and any(c.strip() for c in row)
    ]
    if not rows:
        raise CalibrationInputError(f"{path}: empty file; expected a header u,v,x,y,z or u,v,lat,lon,alt")
    header_line, header = rows[0]
    header = [h.strip().lower() for h in header]
    local = [c for c in ("x", "y", "z") if c in header]
    geo = [c for c in ("lat", "lon", "alt") if c in header]
    if local and geo:
        raise CalibrationInputError(
            f"{path}:{header_line}: the header mixes local columns ({','.join(local)}) and geodetic columns "
            f"({','.join(geo)}); "
            "use either u,v,x,y,z (local metres) or u,v,lat,lon,alt (WGS84), one kind per file"
        )
    columns = GEODETIC_COLUMNS if geo else LOCAL_COLUMNS
    missing = [c for c in columns if c not in header]
    if missing:
        raise CalibrationInputError(
            f"{path}:{header_line}: missing column(s) {', '.join(missing)}; expected a header u,v,x,y,z (local "
            f"metres) or u,v,lat,lon,alt (WGS84)"
        )
    unknown = [h for h in header if h not in columns and h not in ("name", "id")]
    if unknown:
        raise CalibrationInputError(
            f"{path}:{header_line}: unknown column(s) {', '.join(unknown)[:60]}; expected {','.join(columns)} and "
            f"optionally name"
        )
    index = {h: i for i, h in enumerate(header)}
    name_col = index.get("name", index.get("id"))
    values, names, lines = [], [], []
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise CalibrationInputError(
                f"{path}:{line}: expected {len(header)} values ({','.join(header)}), got {len(row)}"
            )
        numbers = []
        for col in columns:
            cell = row[index[col]].strip()
            try:
                number = float(cell)
            except ValueError:
                raise CalibrationInputError(f"{path}:{line}: column '{col}': not a number: {cell[:60]!r}") from None
            if not np.isfinite(number):
                raise CalibrationInputError(f"{path}:{line}: column '{col}': not a finite number: {cell[:60]!r}")
            numbers.append(number)
        if geo and not (-90 <= numbers[2] <= 90 and -180 <= numbers[3] <= 180):
            raise CalibrationInputError(
                f"{path}:{line}: lat/lon out of range ({numbers[2]}, {numbers[3]}); expected degrees"
            )
        values.append(numbers)
        names.append(row[name_col].strip() if name_col is not None else f"line {line}")
        lines.append(line)
    if not values:
        raise CalibrationInputError(f"{path}: no points after the header")
    data = np.array(values, dtype=np.float64)
    return GcpTable(
        str(path), data[:, :2], None if geo else data[:, 2:], data[:, 2:] if geo else None, tuple(names), tuple(lines)
    )


@dataclass(frozen=True)
class Pose:
    """A camera pose (world -> camera) with its fit quality.

    errors: per-point reprojection error (px) with the full lens model;
    inliers: points kept by RANSAC; rms: RMS error of the inliers (px);
    rotation_std_deg / position_std_m: one-sigma uncertainty of the rotation
    and of the camera centre predicted from the residuals (first-order).
    """

    R: np.ndarray
    t: np.ndarray
    errors: np.ndarray
    inliers: np.ndarray
    rms: float
    rotation_std_deg: float
    position_std_m: float
    method: str

    @property
    def center(self) -> np.ndarray:
        return -self.R.T @ self.t

    def to_report(self, names: tuple[str, ...] | None = None) -> dict:
        names = names or tuple(str(i) for i in range(len(self.errors)))
        return {
            "method": self.method,
            "rms_px": self.rms,
            "rotation_std_deg": self.rotation_std_deg,
            "position_std_m": self.position_std_m,
            "camera_center_m": self.center.tolist(),
            "points": [
                {"name": n, "error_px": float(e), "inlier": bool(i)}
                for n, e, i in zip(names, self.errors, self.inliers)
            ],
        }


def pose_from_points(
    uv: np.ndarray,
    xyz: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    dist_model: str = "opencv",
    ransac_px: float = RANSAC_PX,
    source: str = "ground control points",
) -> Pose:
    """World -> camera pose from pixel (N, 2) <-> world (N, 3, metres) pairs.

    SQPnP on all points (fewer than 6) or inside RANSAC (6 or more; points off by
    more than ``ransac_px`` are outliers; RANSAC's samples solved by SQPnP, or
    by AP3P where those find no pose: six exact points on the ground can leave
    SQPnP's samples without one), then Levenberg-Marquardt refinement
    on the inliers. Raises CalibrationInputError for fewer than 4 points,
    collinear points, or points that end up behind the camera.
    """
    import cv2

    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if len(uv) != len(xyz):
        raise CalibrationInputError(f"{source}: {len(uv)} pixel positions but {len(xyz)} world points")
    if len(uv) < MIN_POINTS:
        raise CalibrationInputError(f"{source}: {len(uv)} points, at least {MIN_POINTS} are needed for a camera pose")
    _check_spread(xyz, source, "world points", "m", 1e-3)
    _check_spread(uv, source, "pixel positions", "px", 1.0)
    ideal = undistort_pixels(uv, K, dist, dist_model, P=K)
    inliers = np.ones(len(uv), dtype=bool)
    method = "SQPnP"
    if len(uv) >= RANSAC_MIN_POINTS:
        for flags in (cv2.SOLVEPNP_SQPNP, cv2.SOLVEPNP_AP3P):  # AP3P's minimal samples: where SQPnP's find no pose
            ok, rvec, tvec, idx = cv2.solvePnPRansac(
                xyz,
                ideal,
                K,
                None,
                iterationsCount=500,
                reprojectionError=ransac_px,
                confidence=0.999,
                flags=flags,
            )
            if ok and idx is not None and len(idx) >= MIN_POINTS:
                break
        if not ok or idx is None or len(idx) < MIN_POINTS:
            raise CalibrationInputError(
                f"{source}: no pose explains at least {MIN_POINTS} points within {ransac_px:g} px; check that each "
                f"pixel matches its world point"
            )
        inliers = np.zeros(len(uv), dtype=bool)
        inliers[idx.ravel()] = True
        method = "SQPnP+RANSAC"
    ok, rvec, tvec = cv2.solvePnP(xyz[inliers], ideal[inliers], K, None, flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        raise CalibrationInputError(f"{source}: solvePnP found no pose")
    if dist_model == "fisheye":
        rvec, tvec = cv2.solvePnPRefineLM(xyz[inliers], ideal[inliers], K, None, rvec, tvec)
    else:
        rvec, tvec = cv2.solvePnPRefineLM(xyz[inliers], uv[inliers], K, dist, rvec, tvec)
    method += "+LM"
    R = cv2.Rodrigues(rvec)[0]
    t = tvec.ravel()
    depth = xyz @ R.T[:, 2] + t[2]
    if np.any(depth[inliers] <= 0):
        raise CalibrationInputError(
            f"{source}: the best pose puts {int(np.sum(depth[inliers] <= 0))} points behind the camera; check the "
            f"pixel <-> world pairs and the axes"
        )
    projected = project_points(xyz, rvec, tvec, K, dist, dist_model)
    errors = np.linalg.norm(projected - uv, axis=1)
    rms = float(np.sqrt(np.mean(errors[inliers] ** 2)))
    rot_std, pos_std = _uncertainty(xyz[inliers], uv[inliers], rvec, tvec, K, dist, dist_model, errors[inliers])
    return Pose(R, t, errors, inliers, rms, rot_std, pos_std, method)


def _check_spread(points: np.ndarray, source: str, what: str, unit: str, tolerance: float) -> None:
    centred = points - points.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    if s[0] < tolerance:
        raise CalibrationInputError(
            f"{source}: all {what} are at the same place; a pose needs points spread over the view"
        )
    if s[1] < max(tolerance, 1e-3 * s[0]):
        raise CalibrationInputError(
            f"{source}: the {what} are collinear (on one line, within {s[1] / np.sqrt(len(points)):.3g} {unit}); a "
            f"pose needs points off that line"
        )


def _uncertainty(xyz, uv, rvec, tvec, K, dist, dist_model, errors) -> tuple[float, float]:
    """First-order one-sigma rotation (deg) and camera-centre (m) uncertainty from the residuals."""
    n = len(xyz)
    if 2 * n <= 6:
        return float("nan"), float("nan")
    params = np.concatenate([np.ravel(rvec), np.ravel(tvec)])

    def residual(p):
        return project_points(xyz, p[:3], p[3:], K, dist, dist_model).ravel()

    base = residual(params)
    J = np.empty((2 * n, 6))
    for k in range(6):
        step = np.zeros(6)
        step[k] = 1e-6
        J[:, k] = (residual(params + step) - base) / 1e-6
    sigma2 = float(np.sum(errors**2)) / (2 * n - 6)
    try:
        cov = sigma2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return float("nan"), float("nan")

    # Camera centre C = -R^T t: propagate numerically.
    def centre(p):
        import cv2

        return -cv2.Rodrigues(p[:3])[0].T @ p[3:]

    c0 = centre(params)
    Jc = np.column_stack([(centre(params + np.eye(6)[k] * 1e-6) - c0) / 1e-6 for k in range(6)])
    pos_var = np.trace(Jc @ cov @ Jc.T)
    rot_var = np.trace(cov[:3, :3])
    return float(np.degrees(np.sqrt(rot_var))), float(np.sqrt(pos_var))


def pose_from_board(
    gray: np.ndarray,
    corners: np.ndarray,
    pattern: Pattern,
    board_R: np.ndarray,
    board_t: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    dist_model: str = "opencv",
    source: str = "board image",
) -> Pose:
    """World -> camera pose from a board lying at a known world pose (board -> world: X_world = board_R @ X_board +
    board_t).

    Board frame: origin at the inner corner next to a dark outer corner square,
    x along the pattern's columns, y along its rows, z = x cross y pointing into
    the board (away from the camera). The detector's corner order is brought to
    this frame by checking which side the camera is on and which squares are
    dark, so the pattern needs one odd and one even count of inner corners.
    """
    import cv2

    if (pattern.cols + pattern.rows) % 2 == 0:
        raise CalibrationInputError(
            f"{source}: a {pattern} board looks the same turned by 180 degrees, so its pose is ambiguous; use a board "
            f"with one odd and one even count of inner corners (e.g. 7x6)"
        )
    board = pattern.object_points()
    grid = corners.reshape(pattern.rows, pattern.cols, 2)
    chosen = None
    for order in (grid, grid[::-1, ::-1], grid[:, ::-1], grid[::-1, :]):
        pts = order.reshape(-1, 2)
        ideal = undistort_pixels(pts, K, dist, dist_model, P=K)
        ok, rvec, tvec = cv2.solvePnP(board, ideal, K, None, flags=cv2.SOLVEPNP_IPPE)
        if not ok:
            continue
        R_cb = cv2.Rodrigues(rvec)[0]
        if (-R_cb.T @ tvec.ravel())[2] >= 0:  # camera must be on the board's -z side
            continue
        s = pattern.square
        probes = np.array([[-0.5, -0.5, 0], [0.5, 0.5, 0], [0.5, -0.5, 0], [-0.5, 0.5, 0]]) * s
        at = project_points(probes, rvec, tvec, K, dist, dist_model)
        level = [float(cv2.getRectSubPix(gray, (3, 3), (float(x), float(y))).mean()) for x, y in at]
        if level[0] + level[1] < level[2] + level[3]:
            chosen = pts
            break
    if chosen is None:
        raise CalibrationInputError(f"{source}: cannot tell the board's orientation (dark corner square not found)")
    # With the corners in the board frame's order, the board's world corners are ordinary control points.
    world = board @ np.asarray(board_R, dtype=np.float64).T + np.asarray(board_t, dtype=np.float64).ravel()
    pose = pose_from_points(chosen, world, K, dist, dist_model, source=source)
    return Pose(
        pose.R,
        pose.t,
        pose.errors,
        pose.inliers,
        pose.rms,
        pose.rotation_std_deg,
        pose.position_std_m,
        "board+" + pose.method,
    )
