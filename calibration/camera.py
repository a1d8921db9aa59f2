"""The calibrated camera and its ``camera.json`` file.

Conventions: world points are in the trajectory's local metric frame (metres);
camera coordinates are X_cam = R @ X_world + t (OpenCV: x right, y down,
z forward); pixels have their origin at the centre of the top-left pixel;
``dist`` is OpenCV's order (k1, k2, p1, p2[, k3[, k4, k5, k6]]) for the
``opencv`` model, or (k1, k2, k3, k4) for the ``fisheye`` model.

A camera.json without a pose (no R, t) is a camera whose pose is to be
estimated (from the target); one without K either, a camera whose
intrinsics are to be estimated too (``Camera.to_estimate``). Such a camera
cannot project until they are. ``pose`` in camera.json says where a pose
comes from and how good it is (``PoseInfo``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from calibration.errors import CalibrationInputError, read_text
from calibration.lens import DISTORTION_MODELS, distort_normalized, distortion_jacobian

_OPENCV_DIST_LENGTHS = (4, 5, 8, 12, 14)

# Projected points whose undistorted (pinhole) position lies further than this
# fraction of the image size outside the image are dropped: the distortion
# polynomial is only valid near the calibrated area and folds back beyond it.
OUTSIDE_MARGIN = 0.5
MAX_IMAGE_SIDE = 100_000  # pixels: no camera's image is wider or higher
CENTRE_SLACK = 0.45  # the principal point lies within this fraction of the image's size from its centre ...
SAME_FACTOR = 0.1  # ... unless moved off it along one axis, or by factors this far apart (a crop, not a resolution)

POSE_SOURCES = ("gcp", "board", "target", "gcp+target")
GUESSED_FOCAL = 1.0  # focal length of a camera without K, in image widths (about 53 degrees across): the search's start


@dataclass(frozen=True)
class PoseInfo:
    """Where a camera's pose comes from and how good it is (``pose`` in camera.json).

    source: one of POSE_SOURCES; center_std_m: one-sigma uncertainty of the
    camera centre (metres); rotation_std_deg: of its rotation (degrees)
    (None: not known); for_3d: False when the pose serves timing but not 3D
    (fitted to a log whose error is metre-level, which the pose absorbs);
    note: what the user should know, or "".
    """

    source: str
    center_std_m: float | None = None
    rotation_std_deg: float | None = None
    for_3d: bool = True
    note: str = ""

    def to_dict(self) -> dict:
        out: dict = {
            "source": self.source,
            "center_std_m": self.center_std_m,
            "rotation_std_deg": self.rotation_std_deg,
            "for_3d": self.for_3d,
        }
        if self.note:
            out["note"] = self.note
        return out

    @classmethod
    def from_dict(cls, data, source: str) -> PoseInfo:
        if not isinstance(data, dict) or data.get("source") not in POSE_SOURCES:
            raise CalibrationInputError(
                f"{source}: field 'pose': expected an object with 'source' one of {', '.join(POSE_SOURCES)}, got "
                f"{data!r}"
            )
        values = {}
        for key in ("center_std_m", "rotation_std_deg"):
            value = data.get(key)
            if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0):
                raise CalibrationInputError(
                    f"{source}: field 'pose.{key}': expected a non-negative number or null, got {value!r}"
                )
            values[key] = None if value is None else float(value)
        for_3d = data.get("for_3d", True)
        if not isinstance(for_3d, bool):
            raise CalibrationInputError(f"{source}: field 'pose.for_3d': expected true or false, got {for_3d!r}")
        return cls(
            data["source"], values["center_std_m"], values["rotation_std_deg"], for_3d, str(data.get("note", ""))
        )


@dataclass(frozen=True)
class Camera:
    """A stationary calibrated camera.

    K: 3x3 intrinsics (pixels); dist: distortion coefficients; R: 3x3 rotation
    world->camera; t: translation (metres); image_size: (width, height) in
    pixels; fps: nominal frame rate (frames per second) or None;
    to_estimate: what the camera does not know yet, "pose" (R is the
    identity and t zero until then) and "intrinsics" (K a guess);
    pose_info: where the pose comes from and how good it is, or None.
    """

    name: str
    K: np.ndarray
    dist: np.ndarray
    R: np.ndarray
    t: np.ndarray
    image_size: tuple[int, int]
    fps: float | None = None
    dist_model: str = "opencv"
    extra: dict = field(default_factory=dict, compare=False)
    to_estimate: tuple[str, ...] = ()
    pose_info: PoseInfo | None = None

    @property
    def posed(self) -> bool:
        """Whether the camera has a pose (it can project)."""
        return "pose" not in self.to_estimate

    def without_pose(self) -> Camera:
        """This camera with its pose still to be estimated (R the identity, t zero, no pose_info)."""
        return replace(self, R=np.eye(3), t=np.zeros(3), to_estimate=("pose",), pose_info=None)

    @property
    def rvec(self) -> np.ndarray:
        """Rodrigues rotation vector of R (radians)."""
        import cv2  # OpenCV loads with the first camera that needs it, not with the module

        return cv2.Rodrigues(self.R)[0].ravel()

    @property
    def center(self) -> np.ndarray:
        """Camera centre in world coordinates (metres)."""
        return -self.R.T @ self.t

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project world points (N, 3) to pixels with distortion.

        Returns (uv, valid): uv is (N, 2) in pixels, valid is a boolean mask
        that is False for points behind the camera or far outside the image
        (see OUTSIDE_MARGIN); uv is NaN where valid is False.
        """
        if not self.posed:
            raise ValueError(f"camera {self.name}: its pose is still to be estimated; it cannot project")
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        cam = points @ self.R.T + self.t
        z = cam[:, 2]
        valid = z > 1e-6
        with np.errstate(divide="ignore", invalid="ignore"):
            normalized = cam[:, :2] / z[:, None]
        pinhole = normalized * [self.K[0, 0], self.K[1, 1]] + [self.K[0, 2], self.K[1, 2]]
        pinhole[:, 0] += self.K[0, 1] * normalized[:, 1]
        w, h = self.image_size
        mx, my = OUTSIDE_MARGIN * w, OUTSIDE_MARGIN * h
        valid &= (pinhole[:, 0] > -mx) & (pinhole[:, 0] < w + mx)
        valid &= (pinhole[:, 1] > -my) & (pinhole[:, 1] < h + my)
        if len(points) and valid.all():  # every point in view: no copy in and out of a mask
            return self._distort(normalized), valid
        uv = np.full((len(points), 2), np.nan)
        if valid.any():
            uv[valid] = self._distort(normalized[valid])
        return uv, valid

    def point_jacobian(self, points: np.ndarray) -> np.ndarray | None:
        """(N, 2, 3) derivative of the pixels (``project``'s) in the world points (N, 3: pixels per metre), analytic;
        None for a lens model without an analytic derivative here (lens.distortion_jacobian). Not finite for points
        behind the camera."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        cam = points @ self.R.T + self.t
        with np.errstate(divide="ignore", invalid="ignore"):
            inverse = 1.0 / cam[:, 2]
            normalized = cam[:, :2] * inverse[:, None]
        lens = distortion_jacobian(normalized, self.K, self.dist, self.dist_model)
        if lens is None:
            return None
        pinhole = np.zeros((len(points), 2, 3))  # d normalized / d camera point
        pinhole[:, 0, 0] = pinhole[:, 1, 1] = inverse
        pinhole[:, :, 2] = -normalized * inverse[:, None]
        return lens @ pinhole @ self.R

    def pixels_per_metre(self, points: np.ndarray, uv: np.ndarray, step_m: float = 1e-3) -> np.ndarray:
        """(N, 2, 3) derivative of the pixels in the world points (N, 3): ``point_jacobian`` where the lens model has
        one, else forward differences of ``step_m`` metres from the points' pixels ``uv`` (``project``'s, N x 2)."""
        analytic = self.point_jacobian(points)
        if analytic is not None:
            return analytic
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        moved, _ = self.project(np.concatenate([points + step_m * axis for axis in np.eye(3)]))
        n = len(points)
        return np.stack([(moved[a * n : (a + 1) * n] - uv) / step_m for a in range(3)], axis=2)

    def _distort(self, normalized: np.ndarray) -> np.ndarray:
        """Pixels of normalized image points (N, 2) through the lens model."""
        return distort_normalized(normalized, self.K, self.dist, self.dist_model)

    def in_image(self, uv: np.ndarray) -> np.ndarray:
        """Boolean mask of pixel positions (N, 2) inside the image."""
        w, h = self.image_size
        x, y = uv[:, 0], uv[:, 1]
        return (x >= -0.5) & (x <= w - 0.5) & (y >= -0.5) & (y <= h - 0.5)

    def to_dict(self) -> dict:
        """The ``camera.json`` content (contract in docs/formats.md)."""
        out: dict = {"name": self.name}
        if "intrinsics" not in self.to_estimate:
            out["K"] = self.K.tolist()
        out["dist"] = self.dist.tolist()
        if self.posed:
            out.update(R=self.R.tolist(), t=self.t.tolist())
        out["image_size"] = list(self.image_size)
        if self.pose_info is not None:
            out["pose"] = self.pose_info.to_dict()
        if self.dist_model != "opencv":
            out["dist_model"] = self.dist_model
        if self.fps is not None:
            out["fps"] = self.fps
        out.update(self.extra)
        return out

    @classmethod
    def from_dict(cls, data: dict, source: str = "camera", name: str | None = None) -> Camera:
        """Build a camera from ``camera.json`` content.

        Accepts ``K`` + ``dist`` + (``R`` + ``t`` | ``rvec`` + ``tvec``), or a
        3x4 ``P`` (decomposed into K, R, t; no distortion unless ``dist``).
        Without any pose field the pose is to be estimated; without K
        either, the intrinsics too (K is then a guess: GUESSED_FOCAL image
        widths, the principal point at the centre). Raises
        CalibrationInputError naming ``source`` and the field.
        """
        if not isinstance(data, dict):
            raise CalibrationInputError(f"{source}: expected a JSON object, got {type(data).__name__}")
        known = {"name", "K", "dist", "R", "t", "rvec", "tvec", "P", "image_size", "fps", "dist_model", "pose"}
        extra = {k: v for k, v in data.items() if k not in known}
        dist_model = data.get("dist_model", "opencv")
        if dist_model not in DISTORTION_MODELS:
            raise CalibrationInputError(
                f"{source}: field 'dist_model': expected one of {', '.join(DISTORTION_MODELS)}, got {dist_model!r}"
            )
        to_estimate: tuple[str, ...] = ()
        image_size = _image_size(data, source)
        if "P" in data:
            if "K" in data or "R" in data:
                raise CalibrationInputError(f"{source}: give either 'P' or 'K' with 'R'/'rvec', not both")
            K, R, t = _decompose_projection(_matrix(data, "P", (3, 4), source), source)
        else:
            if not any(k in data for k in ("R", "t", "rvec", "tvec")):
                to_estimate = ("pose",)
                R, t = np.eye(3), np.zeros(3)
            else:
                R, t = _pose(data, source)
            if "K" not in data and to_estimate:
                to_estimate = ("pose", "intrinsics")
                w, h = image_size
                K = np.array(
                    [[GUESSED_FOCAL * w, 0.0, (w - 1) / 2], [0.0, GUESSED_FOCAL * w, (h - 1) / 2], [0.0, 0.0, 1.0]]
                )
            else:
                K = _matrix(data, "K", (3, 3), source)
        _check_intrinsics(K, source)
        dist = _distortion(data.get("dist", [0.0] * 5), dist_model, source)
        if data.get("cropped") is not True:
            _check_principal_point(K, image_size, source)
        fps = data.get("fps")
        if fps is not None:
            fps = _positive_number(fps, "fps", source)
        cam_name = name if name is not None else data.get("name", Path(source).stem)
        if not isinstance(cam_name, str) or not cam_name:
            raise CalibrationInputError(f"{source}: field 'name': expected a non-empty string")
        pose_info = PoseInfo.from_dict(data["pose"], source) if data.get("pose") is not None else None
        return cls(cam_name, K, dist, R, t, image_size, fps, dist_model, extra, to_estimate, pose_info)


def read_camera(path: str | Path, name: str | None = None) -> Camera:
    """Read and validate a ``camera.json`` file."""
    path = Path(path)
    text = read_text(path)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise CalibrationInputError(f"{path}:{exc.lineno}: invalid JSON: {exc.msg}") from None
    return Camera.from_dict(data, source=str(path), name=name)


def write_camera(camera: Camera, path: str | Path) -> None:
    """Write ``camera.json`` (not atomic: callers that cache use an atomic writer)."""
    Path(path).write_text(json.dumps(camera.to_dict(), indent=1) + "\n", encoding="utf-8")


def _matrix(data: dict, key: str, shape: tuple[int, ...], source: str) -> np.ndarray:
    if key not in data:
        raise CalibrationInputError(f"{source}: missing field '{key}'")
    try:
        value = np.asarray(data[key], dtype=np.float64)
    except (TypeError, ValueError):
        raise CalibrationInputError(f"{source}: field '{key}': expected numbers, got {data[key]!r}") from None
    if value.size == math.prod(shape) and value.ndim == 1 and len(shape) == 2:
        raise CalibrationInputError(
            f"{source}: field '{key}': expected a {shape[0]}x{shape[1]} matrix (list of rows), got a flat list"
        )
    if value.shape != shape:
        want = "x".join(map(str, shape))
        raise CalibrationInputError(f"{source}: field '{key}': expected shape {want}, got {value.shape}")
    if not np.all(np.isfinite(value)):
        raise CalibrationInputError(f"{source}: field '{key}': contains NaN or infinity")
    return value


def _pose(data: dict, source: str) -> tuple[np.ndarray, np.ndarray]:
    if "R" in data and "rvec" in data:
        raise CalibrationInputError(f"{source}: give either 'R' or 'rvec', not both")
    if "rvec" in data:
        import cv2

        R = cv2.Rodrigues(_matrix(data, "rvec", (3,), source))[0]
        t = _matrix(data, "tvec", (3,), source)
        return R, t
    R = _matrix(data, "R", (3, 3), source)
    t = _matrix(data, "t", (3,), source)
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
        raise CalibrationInputError(f"{source}: field 'R': not a rotation matrix (R^T R != I or det(R) < 0)")
    u, _, vt = np.linalg.svd(R)  # remove rounding from a written-out rotation
    return u @ vt, t


def _decompose_projection(P: np.ndarray, source: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if abs(np.linalg.det(P[:, :3])) < 1e-12:
        raise CalibrationInputError(f"{source}: field 'P': its left 3x3 block is singular")
    import cv2

    K, R, center_h = cv2.decomposeProjectionMatrix(P)[:3]
    # Make the focal lengths positive (RQ decomposition leaves signs free).
    signs = np.diag(np.sign(np.diag(K)))
    K, R = K @ signs, signs @ R
    if np.linalg.det(R) < 0:
        R = -R
    K = K / K[2, 2]
    center = center_h[:3, 0] / center_h[3, 0]
    return K, R, -R @ center


def _check_intrinsics(K: np.ndarray, source: str) -> None:
    if abs(np.linalg.det(K)) < 1e-9 or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise CalibrationInputError(
            f"{source}: field 'K': singular or non-positive focal lengths (fx={K[0, 0]:g}, fy={K[1, 1]:g})"
        )
    if np.abs(K[2] - [0, 0, 1]).max() > 1e-9 or K[1, 0] != 0:
        raise CalibrationInputError(f"{source}: field 'K': expected upper-triangular with last row [0, 0, 1]")


def _check_principal_point(K: np.ndarray, image_size: tuple[int, int], source: str) -> None:
    """The principal point (cx, cy) where a K of this image puts it: near the centre, or off it the way a crop moves it.

    The mistake this catches is an image_size of another resolution (or another K): it moves the principal point
    off the centre along both axes by one factor (cx / (w / 2) = cy / (h / 2) = the resolutions' ratio). A camera
    cropped from a wider one may have it anywhere, even outside the image, but by one factor on both axes only
    when cut at a corner: its camera.json says ``"cropped": true``, which skips the check.
    """
    factors = [centre / (side / 2) for centre, side in zip(K[:2, 2], image_size)]
    off = [abs(centre - side / 2) > CENTRE_SLACK * side for centre, side in zip(K[:2, 2], image_size)]
    if all(off) and abs(factors[0] - factors[1]) <= SAME_FACTOR * max(abs(factors[0]), abs(factors[1])):
        raise CalibrationInputError(
            f"{source}: field 'K': principal point ({K[0, 2]:g}, {K[1, 2]:g}) px is off the centre of the "
            f"{image_size[0]} x {image_size[1]} "
            f"image (field 'image_size') by a factor {np.mean(factors):.3g} on both axes: K and image_size are of "
            f"different resolutions "
            '(for a camera cropped at a corner of a wider one: "cropped": true)'
        )


def _distortion(value, dist_model: str, source: str) -> np.ndarray:
    try:
        dist = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise CalibrationInputError(f"{source}: field 'dist': expected a list of numbers, got {value!r}") from None
    lengths = (4,) if dist_model == "fisheye" else _OPENCV_DIST_LENGTHS
    if len(dist) not in lengths:
        raise CalibrationInputError(
            f"{source}: field 'dist': expected {' or '.join(map(str, lengths))} coefficients for the {dist_model} "
            f"model, got {len(dist)}"
        )
    if not np.all(np.isfinite(dist)):
        raise CalibrationInputError(f"{source}: field 'dist': contains NaN or infinity")
    return dist


def _image_size(data: dict, source: str) -> tuple[int, int]:
    size = data.get("image_size")
    if size is None:
        raise CalibrationInputError(f"{source}: missing field 'image_size' ([width, height] in pixels)")
    if (
        not isinstance(size, (list, tuple))
        or len(size) != 2
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and v == int(v) and v > 0 for v in size)
    ):
        raise CalibrationInputError(
            f"{source}: field 'image_size': expected [width, height] as positive integers, got {size!r}"
        )
    if max(size) > MAX_IMAGE_SIDE:
        raise CalibrationInputError(
            f"{source}: field 'image_size': {list(size)} pixels; no camera's image is wider or higher than "
            f"{MAX_IMAGE_SIDE}"
        )
    return int(size[0]), int(size[1])


def _positive_number(value, key: str, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise CalibrationInputError(f"{source}: field '{key}': expected a positive number, got {value!r}")
    return float(value)
