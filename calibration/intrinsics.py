"""Zhang intrinsics from checkerboard photos or a checkerboard video (OpenCV).

Corner detection: the classic detector (adaptive threshold) on a copy downscaled
to about ``CLASSIC_SIZE`` px on its long side, then the sector-based detector
(findChessboardCornersSB) on a copy of about ``DETECT_SIZE`` px, then, where a part
of a checker grid is seen, the sector-based detector in exhaustive mode; the
corners found are refined at full resolution with cornerSubPix (the same corners,
to 0.01 px, whichever detector found them). Images are
processed in parallel (one process per core, one OpenCV thread each).

Calibration: cv2.calibrateCamera with the 5-parameter model ("standard", k1 k2
p1 p2 k3), the rational 8-parameter model ("rational") or cv2.fisheye ("fisheye",
k1..k4). Pixels are not forced square (fx and fy are free). Views whose RMS
reprojection error exceeds max(OUTLIER_FACTOR * median, ``max_view_error``) are
dropped and the camera is calibrated again. Pixel (0, 0) is the centre of the
top-left pixel; board points are in metres.
"""

from __future__ import annotations

import glob as globlib
import multiprocessing
import os
import re
import signal
from collections import Counter
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from calibration.camera import Camera
from calibration.choices import MAX_FRAMES, MAX_VIEW_ERROR, MODEL_LENS, MODELS, parse_corners
from calibration.errors import CalibrationInputError, PatternMismatch
from calibration.lens import project_points

# Calibration model -> the lens model (calibration.lens) of the cameras it makes.
DETECT_SIZE = 720  # about the long side (px) of the copy the board is first looked for in
CLASSIC_SIZE = 1280  # about the long side (px) of the copy for the classic detector
EXHAUSTIVE_SIZE = 2000  # at most the long side (px) of the copy for the last, exhaustive try
SMOOTH_DIVISOR = 30.0  # corner refinement smooths with sigma = square spacing (px) / this
MIN_VIEWS = 5
OUTLIER_FACTOR = 3.0
NO_BOARD = "no board found"  # the diagnosis when not even a 3x3 part of a checker grid is seen
DUPLICATE_FRACTION = 0.004  # views whose corners moved less than this * image diagonal are duplicates
TRIED = (
    f"the classic detector (findChessboardCorners, adaptive threshold + normalized image) on a copy downscaled to "
    f"about {CLASSIC_SIZE} px, "
    "the sector-based detector (findChessboardCornersSB, normalized image) at about {small} px "
    f"and, where a part of a board is seen, the sector-based detector in exhaustive mode at up to {EXHAUSTIVE_SIZE} px"
)


@dataclass(frozen=True)
class Pattern:
    """A checkerboard: inner corners (columns x rows) and the square side in metres."""

    cols: int
    rows: int
    square: float

    @property
    def size(self) -> tuple[int, int]:
        return self.cols, self.rows

    def __str__(self) -> str:
        return f"{self.cols}x{self.rows}"

    def object_points(self) -> np.ndarray:
        """(cols * rows, 3) inner-corner coordinates on the board (metres), row by row: corner (i, j) at (i, j, 0) *
        square.
        """
        grid = np.mgrid[0 : self.cols, 0 : self.rows].T.reshape(-1, 2) * self.square
        return np.column_stack([grid, np.zeros(len(grid))])


def parse_pattern(text: str, square: float, source: str = "pattern") -> Pattern:
    """``"7x6"`` (inner corners, columns x rows) and the square side (m) -> Pattern."""
    try:
        cols, rows = parse_corners(text)
    except CalibrationInputError as exc:
        raise CalibrationInputError(f"{source}: {exc}") from None
    if isinstance(square, bool) or not isinstance(square, (int, float)) or not np.isfinite(square) or square <= 0:
        raise CalibrationInputError(f"{source}: the square side must be a positive length in metres, got {square!r}")
    return Pattern(cols, rows, float(square))


@dataclass(frozen=True)
class Detection:
    """What was found in one image: full-resolution corners (N, 2) row by row, or why not."""

    source: str
    image_size: tuple[int, int] | None  # (width, height); None when unreadable
    corners: np.ndarray | None
    method: str | None  # "sb", "sb-exhaustive" or "classic"
    reason: str | None  # set when corners is None


def detect_board(
    gray: np.ndarray, pattern: tuple[int, int], detect_size: int = DETECT_SIZE
) -> tuple[np.ndarray | None, str | None, str | None]:
    """Find the inner corners of a ``pattern`` (cols, rows) board in a grey image.

    Tries, cheapest first: the classic detector on a copy reduced by an
    integer factor to about CLASSIC_SIZE px (a few ms where the board is
    clear; its quick check for checker corners first, so a photo without
    any gives up in about 15 ms at 720p instead of 0.2-0.5 s), the
    sector-based detector at about ``detect_size`` px, and, when
    a part of a checker grid is seen in that copy (the diagnosis), the
    sector-based detector in exhaustive mode at up to EXHAUSTIVE_SIZE px
    (hundreds of ms, not spent on a photo without any board). The classic
    detector takes 0.1-0.7 s at 720p to give up on a photo with part of a
    board: when it fails on a copy of half its size first (a quarter of
    its time; a few ms where the board is clear), the sector-based
    detector goes first, and the classic one runs after it only where that
    found the board (its corners preferred, as in the order above) or the
    diagnosis sees more than a smaller part of a grid (not a cut-off
    board). Returns (corners (N, 2) float64 at full resolution row by row, or None;
    the method that found them; the reason when none did).
    """
    import cv2

    copies: dict[int, np.ndarray] = {}

    def reduced(factor: int) -> np.ndarray:
        if factor not in copies:
            copies[factor] = _reduce(gray, factor)
        return copies[factor]

    def classic(img: np.ndarray):
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
        return cv2.findChessboardCorners(img, pattern, flags=flags)

    def sector_based(img: np.ndarray):
        return cv2.findChessboardCornersSB(img, pattern, flags=cv2.CALIB_CB_NORMALIZE_IMAGE)

    def exhaustive(img: np.ndarray):
        return cv2.findChessboardCornersSB(img, pattern, flags=cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_EXHAUSTIVE)

    grids: list[tuple[int, int] | None] = []  # the grid _seen_grid sees in the detect-size copy, once looked for

    def seen() -> tuple[int, int] | None:
        if not grids:
            grids.append(_seen_grid(reduced(first)))
        return grids[0]

    def attempt(method: str, factor: int, find) -> tuple[np.ndarray | None, str | None, str | None] | None:
        """The detection's answer when ``find`` finds the board in the copy reduced by ``factor``, else None."""
        found, corners = find(reduced(factor))
        if not found or corners is None or len(corners) != pattern[0] * pattern[1]:
            return None
        corners = _refine(gray, (corners.reshape(-1, 2).astype(np.float64) + 0.5) * factor - 0.5, pattern)
        if _extends_beyond(gray, corners, pattern):
            # A part of a larger board: the pattern is wrong, or the views would be inconsistent.
            return None, None, _diagnose(seen(), pattern, larger=True)
        return corners, method, None

    long_side = max(gray.shape[:2])
    first = max(1, round(long_side / detect_size))
    classic_factor = max(1, round(long_side / CLASSIC_SIZE))
    gate_factor = max(1, round(long_side / (CLASSIC_SIZE / 2)))
    if gate_factor == classic_factor or classic(reduced(gate_factor))[0]:
        answer = attempt("classic", classic_factor, classic) or attempt("sb", first, sector_based)
    else:  # the same answers in another order, the classic detector last and not on a cut-off board
        by_sector = attempt("sb", first, sector_based)
        if by_sector is not None:
            answer = attempt("classic", classic_factor, classic) or by_sector
        elif not _within(seen(), _sorted(pattern)):
            answer = attempt("classic", classic_factor, classic)
        else:
            answer = None
    if answer is not None:
        return answer
    reason = _diagnose(seen(), pattern)
    if reason == NO_BOARD:
        return None, None, reason
    return attempt("sb-exhaustive", max(1, -(-long_side // EXHAUSTIVE_SIZE)), exhaustive) or (None, None, reason)


def _reduce(gray: np.ndarray, factor: int) -> np.ndarray:
    """Area-average by an integer factor (the last < factor rows/columns are dropped): OpenCV's fast path, and
    a corner at (u, v) in the copy is at ((u + 0.5) * factor - 0.5, ...) in the image."""
    import cv2

    if factor == 1:
        return gray
    h, w = gray.shape[:2]
    h, w = h // factor, w // factor
    return cv2.resize(gray[: h * factor, : w * factor], (w, h), interpolation=cv2.INTER_AREA)


def _refine(gray: np.ndarray, corners: np.ndarray, pattern: tuple[int, int]) -> np.ndarray:
    """cornerSubPix at full resolution, window scaled to the board's smallest square.

    Where squares are large (phones, 4K), the board's region is first smoothed with
    a Gaussian of sigma = spacing / SMOOTH_DIVISOR: it averages out sensor noise and
    a screen's pixel grid, and does not move a checker corner (point symmetric).
    """
    import cv2

    grid = corners.reshape(pattern[1], pattern[0], 2)
    spacing = min(
        np.linalg.norm(np.diff(grid, axis=0), axis=2).min(), np.linalg.norm(np.diff(grid, axis=1), axis=2).min()
    )
    half = int(np.clip(0.4 * spacing, 2, 30))
    sigma = min(spacing / SMOOTH_DIVISOR, 4.0)
    h, w = gray.shape[:2]
    margin = half + 4 * max(sigma, 1.0) + 2
    x0, y0 = (int(max(0, np.floor(v))) for v in corners.min(axis=0) - margin)
    x1, y1 = (int(min(lim, np.ceil(v))) for v, lim in zip(corners.max(axis=0) + margin, (w, h)))
    roi = gray[y0:y1, x0:x1]
    if sigma >= 1.0:
        roi = cv2.GaussianBlur(roi, (0, 0), sigma)
    pts = (corners - [x0, y0]).astype(np.float32).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 0.001)
    refined = cv2.cornerSubPix(roi, pts, (half, half), (-1, -1), criteria)
    return refined.reshape(-1, 2).astype(np.float64) + [x0, y0]


def _extends_beyond(gray: np.ndarray, corners: np.ndarray, pattern: tuple[int, int]) -> bool:
    """Whether the checker pattern continues past a side of the found grid (a larger board).

    At each point one step beyond the grid's outer rows and columns, the four
    quadrants along the grid's axes are compared: at a checker corner both
    diagonals differ strongly, at the board's plain border they do not.
    """
    grid = corners.reshape(pattern[1], pattern[0], 2)
    h, w = gray.shape[:2]

    def scores(points, step_a, step_b):
        import cv2

        out = []
        for p, a, b in zip(points, step_a, step_b):
            k = max(3, int(0.2 * min(np.linalg.norm(a), np.linalg.norm(b))))
            probes = [p + 0.3 * (sa * a + sb * b) for sa, sb in ((1, 1), (-1, -1), (1, -1), (-1, 1))]
            if not all(k <= x < w - k and k <= y < h - k for x, y in probes):
                out.append(np.nan)
                continue
            q = [float(cv2.getRectSubPix(gray, (k, k), (float(x), float(y))).mean()) for x, y in probes]
            out.append(min(abs(q[i] - q[j]) for i in (0, 1) for j in (2, 3)))
        return np.array(out)

    along_x = grid[:, 1:] - grid[:, :-1]  # step to the next column
    along_y = grid[1:] - grid[:-1]  # step to the next row
    inner = scores(grid[1:-1, 1:-1].reshape(-1, 2), along_x[1:-1, 1:].reshape(-1, 2), along_y[1:, 1:-1].reshape(-1, 2))
    reference = np.nanmedian(inner) if np.isfinite(inner).any() else np.nan
    if not np.isfinite(reference) or reference <= 0:
        return False
    sides = (
        (grid[:, -1] + along_x[:, -1], along_x[:, -1], np.vstack([along_y[:, -1], along_y[-1:, -1]])),
        (grid[:, 0] - along_x[:, 0], along_x[:, 0], np.vstack([along_y[:, 0], along_y[-1:, 0]])),
        (grid[-1] + along_y[-1], np.vstack([along_x[-1], along_x[-1, -1:]]), along_y[-1]),
        (grid[0] - along_y[0], np.vstack([along_x[0], along_x[0, -1:]]), along_y[0]),
    )
    for points, step_a, step_b in sides:
        s = scores(points, step_a, step_b)
        seen = np.isfinite(s)
        if seen.sum() >= 2 and np.mean(s[seen] > 0.5 * reference) > 0.5:
            return True
    return False


def _seen_grid(small: np.ndarray) -> tuple[int, int] | None:
    """The inner corners (larger, smaller) of the largest checker grid the sector-based detector grows from a 3 x 3
    part of one in ``small``; None when it sees none."""
    import cv2

    found, corners, meta = cv2.findChessboardCornersSBWithMeta(
        small, (3, 3), flags=cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_LARGER
    )
    return _sorted(meta.shape[:2]) if found and meta is not None else None


def _sorted(size) -> tuple[int, int]:
    """A grid's two sizes, the larger first."""
    return max(size), min(size)


def _within(seen: tuple[int, int] | None, want: tuple[int, int]) -> bool:
    """Whether a grid seen (sizes sorted) is a smaller part of one of ``want``'s: no larger either way, not equal."""
    return seen is not None and seen[0] <= want[0] and seen[1] <= want[1] and seen != want


def _diagnose(seen: tuple[int, int] | None, pattern: tuple[int, int], larger: bool = False) -> str:
    """Why no full board was found, from the grid seen (``_seen_grid``): a smaller or larger grid visible, or
    nothing."""
    want = _sorted(pattern)
    bigger = seen is not None and (seen[0] > want[0] or seen[1] > want[1])
    if larger and not bigger:
        return f"pattern mismatch: a board with more inner corners than {pattern[0]}x{pattern[1]} found"
    if seen is None:
        return NO_BOARD
    label = f"{seen[0]}x{seen[1]}"
    if bigger:
        return f"pattern mismatch: a board with {label} inner corners found"
    return f"incomplete board: only {label} of the inner corners visible (board cut off, hidden or too oblique)"


def _init_worker() -> None:
    """A detection worker: one OpenCV thread; Ctrl-C (sent to the whole process group) is its parent's to act on."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import cv2

    cv2.setNumThreads(1)


def _detect_item(item) -> Detection:
    """Worker: ``item`` is (source, path or grey array, pattern, detect_size)."""
    import cv2

    source, image, pattern, detect_size = item
    if not isinstance(image, np.ndarray):
        image = cv2.imread(str(image), cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION)
        if image is None:
            return Detection(source, None, None, None, "unreadable: not an image OpenCV can decode")
    size = (image.shape[1], image.shape[0])
    corners, method, reason = detect_board(image, pattern, detect_size)
    return Detection(source, size, corners, method, reason)


def detect_all(
    items: Sequence[tuple[str, object]],
    pattern: Pattern,
    workers: int | None = None,
    detect_size: int = DETECT_SIZE,
    progress: bool = False,
) -> list[Detection]:
    """Detect the board in every (source, path or grey image) item, in parallel, in order."""
    import cv2

    jobs = [(source, image, pattern.size, detect_size) for source, image in items]
    workers = workers or os.cpu_count() or 1
    bar = dict(total=len(jobs), desc="detecting corners", unit="img", disable=not progress, leave=False)
    if workers == 1 or len(jobs) < 3:
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)  # as in the workers: detections do not depend on the path taken
        try:
            return [_detect_item(job) for job in tqdm(jobs, **bar)]
        finally:
            cv2.setNumThreads(threads)
    # Workers come from a fork server, not a fork of this process: forking a process whose
    # OpenCV thread pool has run can deadlock the child.
    context = multiprocessing.get_context(
        "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    )
    pool = ProcessPoolExecutor(max_workers=min(workers, len(jobs)), initializer=_init_worker, mp_context=context)
    try:
        return list(tqdm(pool.map(_detect_item, jobs, chunksize=1), **bar))
    except BaseException:  # Ctrl-C: stop the detections now, not after the running ones (seconds each)
        for process in list((getattr(pool, "_processes", None) or {}).values()):
            process.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    finally:
        pool.shutdown(wait=True)


@dataclass(frozen=True)
class Intrinsics:
    """A calibration result: K (3x3, px), dist, the model, per-view errors (px), which images were used and rejected."""

    K: np.ndarray
    dist: np.ndarray
    dist_model: str  # "opencv" or "fisheye" (Camera.dist_model)
    model: str  # "standard", "rational" or "fisheye"
    image_size: tuple[int, int]
    rms: float  # RMS reprojection error over all corners of the used views (px)
    per_view: dict[str, float]  # used view -> its RMS reprojection error (px)
    used: tuple[str, ...]
    rejected: dict[str, str]  # image -> reason
    corners: dict[str, np.ndarray]  # used view -> (N, 2) detected corners (px)
    pattern: Pattern
    std: dict[str, float]  # one-sigma uncertainty of fx, fy, cx, cy (px) where OpenCV gives it
    methods: dict[str, str]  # used view -> detector that found it

    def camera(self, name: str = "camera", fps: float | None = None) -> Camera:
        """An intrinsics-only Camera: its pose to estimate (from GCPs, a board or the target; camera.json without R, t);
        ``rms`` kept in extra.
        """
        return Camera(
            name,
            self.K.copy(),
            self.dist.copy(),
            np.eye(3),
            np.zeros(3),
            self.image_size,
            fps,
            self.dist_model,
            {"rms": self.rms},
            ("pose",),
        )

    def to_report(self) -> dict:
        """JSON-ready summary: camera, RMS, per-view errors, used and rejected images with reasons."""
        return {
            "model": self.model,
            "pattern": str(self.pattern),
            "square_m": self.pattern.square,
            "image_size": list(self.image_size),
            "K": self.K.tolist(),
            "dist": self.dist.tolist(),
            "dist_model": self.dist_model,
            "std_px": self.std,
            "rms_px": self.rms,
            "views_used": len(self.used),
            "views_rejected": len(self.rejected),
            "per_view": [{"image": s, "rms_px": self.per_view[s], "detector": self.methods[s]} for s in self.used],
            "rejected": [{"image": s, "reason": r} for s, r in self.rejected.items()],
        }


def calibrate_images(
    paths: Iterable[str | Path] | str,
    pattern: Pattern,
    model: str = "standard",
    workers: int | None = None,
    progress: bool = False,
    max_view_error: float = MAX_VIEW_ERROR,
    detect_size: int = DETECT_SIZE,
    label: str | None = None,
) -> Intrinsics:
    """Calibrate from image files (a list, or a glob pattern string); ``label`` names them in messages (default: the
    glob, or "N images").
    """
    if isinstance(paths, str):
        label, files = label or paths, sorted(globlib.glob(os.path.expanduser(paths), recursive=True))
        if not files:
            raise CalibrationInputError(f"{paths}: no files match this pattern")
    else:
        files = [str(p) for p in paths]
        label = label or f"{len(files)} images"
        if not files:
            raise CalibrationInputError("no calibration images given")
    missing = [f for f in files if not Path(f).is_file()]
    if missing:
        raise CalibrationInputError(
            f"{missing[0]}: file not found" + (f" (and {len(missing) - 1} more)" if len(missing) > 1 else "")
        )
    detections = detect_all([(f, f) for f in files], pattern, workers, detect_size, progress)
    return calibrate_detections(detections, pattern, model, label, {}, max_view_error, detect_size)


def calibrate_video(
    path: str | Path,
    pattern: Pattern,
    model: str = "standard",
    max_frames: int = MAX_FRAMES,
    workers: int | None = None,
    progress: bool = False,
    max_view_error: float = MAX_VIEW_ERROR,
    detect_size: int = DETECT_SIZE,
) -> Intrinsics:
    """Calibrate from a video of a moving board: ``max_frames`` frames sampled evenly, blurred and duplicate ones
    skipped.
    """
    frames, skipped = sample_video_frames(path, max_frames, progress)
    detections = detect_all(frames, pattern, workers, detect_size, progress)
    return calibrate_detections(detections, pattern, model, str(path), skipped, max_view_error, detect_size)


def sample_video_frames(
    path: str | Path, max_frames: int = MAX_FRAMES, progress: bool = False, blur_ratio: float = 0.4
) -> tuple[list[tuple[str, np.ndarray]], dict[str, str]]:
    """Evenly sampled grey frames of a video as ("<file>@<frame>", image), and the skipped ones with the reason.

    A frame is "blurred" when its variance of the Laplacian is below ``blur_ratio``
    times the median of the sampled frames, a "duplicate" when it hardly differs
    from the previous kept frame (board and camera still). Frames are 0-based.
    """
    import cv2

    path = Path(path)
    if not path.is_file():
        raise CalibrationInputError(f"{path}: file not found")
    capture = cv2.VideoCapture(str(path))
    if not capture.isOpened():
        raise CalibrationInputError(f"{path}: cannot open the video (unknown format or unreadable)")
    count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
    wanted = set(np.linspace(0, count - 1, min(count, max_frames)).round().astype(int).tolist()) if count > 0 else None
    frames: list[tuple[str, np.ndarray]] = []
    index = 0
    with tqdm(total=count or None, desc="reading video", unit="frame", disable=not progress, leave=False) as bar:
        while wanted is None or index <= max(wanted):
            if not capture.grab():
                break
            if (
                wanted is None
                and index % 15 == 0
                and len(frames) < max_frames
                or wanted is not None
                and index in wanted
            ):
                ok, frame = capture.retrieve()
                if ok:
                    frames.append(
                        (f"{path.name}@{index}", cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame)
                    )
            index += 1
            bar.update()
    capture.release()
    if not frames:
        raise CalibrationInputError(f"{path}: no frame could be decoded")
    sharp = [_sharpness(img) for _, img in frames]
    threshold = blur_ratio * float(np.median(sharp))
    kept, skipped, last = [], {}, None
    for (source, img), s in zip(frames, sharp):
        if s < threshold:
            skipped[source] = f"blurred (variance of Laplacian {s:.0f} < {threshold:.0f})"
            continue
        thumb = cv2.resize(img, (64, 36), interpolation=cv2.INTER_AREA).astype(np.float32)
        if last is not None and np.abs(thumb - last[1]).mean() < 1.5:
            skipped[source] = f"duplicate (same view as {last[0]})"
            continue
        kept.append((source, img))
        last = (source, thumb)
    return kept, skipped


def _sharpness(gray: np.ndarray) -> float:
    import cv2

    small = _reduce(gray, max(2, round(max(gray.shape[:2]) / 480)))  # averaging out sensor noise
    return float(cv2.Laplacian(small, cv2.CV_64F).var())


def calibrate_detections(
    detections: Sequence[Detection],
    pattern: Pattern,
    model: str = "standard",
    label: str = "images",
    rejected: dict[str, str] | None = None,
    max_view_error: float = MAX_VIEW_ERROR,
    detect_size: int = DETECT_SIZE,
) -> Intrinsics:
    """Calibrate from detections: checks sizes, drops duplicates and outlier views, reports why each
    image was rejected.
    """
    if model not in MODELS:
        raise CalibrationInputError(f"model: expected one of {', '.join(MODELS)}, got {model!r}")
    rejected = dict(rejected or {})
    unreadable = [d for d in detections if d.image_size is None]
    if unreadable:
        raise CalibrationInputError(
            f"{unreadable[0].source}: cannot read the image ({unreadable[0].reason})"
            + (f"; {len(unreadable) - 1} more unreadable" if len(unreadable) > 1 else "")
        )
    if not detections:
        raise CalibrationInputError(f"{label}: no images to calibrate from" + _summary(rejected))
    image_size = _common_size(detections, label)
    usable: list[Detection] = []
    for d in detections:
        if d.image_size != image_size:
            assert d.image_size is not None  # unreadable images stopped the calibration above
            rejected[d.source] = (
                f"different size {d.image_size[0]}x{d.image_size[1]} (the calibration uses "
                f"{image_size[0]}x{image_size[1]})"
            )
        elif d.corners is None:
            rejected[d.source] = d.reason or NO_BOARD
        else:
            twin = _duplicate_of(d, usable, image_size)
            if twin is not None:
                rejected[d.source] = f"duplicate (same view as {twin})"
            else:
                usable.append(d)
    mismatched = sum(r.startswith("pattern mismatch") for r in rejected.values())
    if len(usable) < MIN_VIEWS or mismatched > len(usable):
        raise _too_few(label, pattern, detections, usable, rejected, detect_size)
    views = {d.source: d for d in usable}
    while True:
        K, dist, per_view, std = _calibrate(views, pattern, model, image_size)
        errors = np.array(list(per_view.values()))
        limit = max(OUTLIER_FACTOR * float(np.median(errors)), max_view_error)
        worst = [s for s, e in per_view.items() if e > limit]
        if not worst or len(views) - len(worst) < MIN_VIEWS:
            break
        for s in worst:
            rejected[s] = f"outlier (reprojection error {per_view[s]:.2f} px > {limit:.2f} px)"
            del views[s]
    rms = float(np.sqrt(np.mean(errors**2)))  # every view has the same number of corners
    return Intrinsics(
        K=K,
        dist=dist,
        dist_model=MODEL_LENS[model],
        model=model,
        image_size=image_size,
        rms=rms,
        per_view=per_view,
        used=tuple(views),
        rejected=rejected,
        corners={s: _found(d) for s, d in views.items()},
        pattern=pattern,
        std=std,
        methods={s: d.method or "" for s, d in views.items()},
    )


def _found(d: Detection) -> np.ndarray:
    """The corners of a view where the board was found."""
    assert d.corners is not None, "only views with corners are calibrated"
    return d.corners


def _common_size(detections: Sequence[Detection], label: str) -> tuple[int, int]:
    counts = Counter(d.image_size for d in detections if d.image_size is not None)
    size, n = counts.most_common(1)[0]
    if len(counts) > 1 and n < 2 * len(detections) / 3:
        listing = "; ".join(
            f"{w}x{h}: {c} (e.g. {Path(next(d.source for d in detections if d.image_size == (w, h))).name})"
            for (w, h), c in counts.most_common()
        )
        raise CalibrationInputError(
            f"{label}: the images have different sizes ({listing}); calibrate each camera and resolution separately"
        )
    return size


def _duplicate_of(d: Detection, kept: list[Detection], image_size: tuple[int, int]) -> str | None:
    tolerance = DUPLICATE_FRACTION * float(np.hypot(*image_size))
    for other in kept:
        if np.linalg.norm(_found(d) - _found(other), axis=1).mean() < tolerance:
            return other.source
    return None


def _summary(rejected: dict[str, str]) -> str:
    if not rejected:
        return ""
    kinds = Counter(r.split(" (")[0].split(":")[0] for r in rejected.values())
    return "; rejected: " + ", ".join(f"{n} {k}" for k, n in kinds.most_common())


_SEEN = re.compile(
    r"(?:only|with) (\d+)x(\d+) (?:of the )?inner corners"
)  # the grid a rejection reason says it saw (_diagnose)


def board_shown(reasons: Iterable[str], pattern: Pattern) -> tuple[str, int] | None:
    """The board most rejected images show instead of ``pattern`` ("COLSxROWS", how many), when it is clear.

    Clear: at least 3 images and more than half of those where a grid was
    seen show the same inner corners, and that is not ``pattern``. A few cut
    off views of the right board show grids of every size, never a majority.
    """
    sizes = Counter(f"{m.group(1)}x{m.group(2)}" for m in map(_SEEN.search, reasons) if m)
    if not sizes:
        return None
    size, count = sizes.most_common(1)[0]
    cols, rows = map(int, size.split("x"))
    if sorted((cols, rows)) == sorted(pattern.size) or count < 3 or 2 * count <= sum(sizes.values()):
        return None
    return size, count


def _too_few(label: str, pattern: Pattern, detections, usable, rejected, detect_size: int) -> CalibrationInputError:
    """Why the views cannot calibrate: one short line (PatternMismatch when the images show another board),
    what was tried and each image's reason as details (the error's notes)."""
    total = len(detections)
    shown = board_shown(rejected.values(), pattern)
    error: CalibrationInputError
    if shown is not None:
        mismatch = PatternMismatch(
            f"{label}: {shown[1]} of {total} images show a {shown[0]} board (inner corners, columns x rows), not "
            f"{pattern}"
        )
        mismatch.seen, mismatch.count, mismatch.total, mismatch.pattern = shown[0], shown[1], total, str(pattern)
        error = mismatch
    elif not usable:
        error = CalibrationInputError(
            f"{label}: no {pattern} board (inner corners, columns x rows) in any of {total} images" + _summary(rejected)
        )
    elif len(usable) >= MIN_VIEWS:
        error = CalibrationInputError(
            f"{label}: the {pattern} board is in {len(usable)} of {total} images, but more show another board; count "
            f"the inner corners, columns x rows"
        )
    else:
        error = CalibrationInputError(
            f"{label}: only {len(usable)} usable views of the {pattern} board in {total} images, at least {MIN_VIEWS} "
            f"are needed" + _summary(rejected)
        )
    error.details = (
        "tried: " + TRIED.format(small=detect_size),
        "\n".join(f"{Path(s).name}: {r}" for s, r in rejected.items()),
    )
    return error


def _calibrate(views: dict[str, Detection], pattern: Pattern, model: str, image_size: tuple[int, int]):
    """One calibration; returns K, dist, per-view RMS errors (px) and the intrinsics' standard deviations."""
    import cv2

    obj = pattern.object_points()
    img_pts = [_found(views[s]) for s in views]
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-10)
    if model == "fisheye":
        objs = [obj.reshape(1, -1, 3) for _ in img_pts]
        imgs = [p.reshape(1, -1, 2) for p in img_pts]
        flags = cv2.CALIB_RECOMPUTE_EXTRINSIC | cv2.CALIB_FIX_SKEW  # OpenCV 5: shared CALIB_* flags
        try:
            _, K, dist, rvecs, tvecs = cv2.fisheye.calibrate(
                objs, imgs, image_size, None, None, flags=flags, criteria=criteria
            )
        except cv2.error as exc:
            raise CalibrationInputError(
                f"fisheye calibration failed ({exc.err}); try more views spread over the image"
            ) from None
        std = {}
        dist = dist.ravel()
    else:
        flags = cv2.CALIB_RATIONAL_MODEL if model == "rational" else 0
        objs = [obj.astype(np.float32) for _ in img_pts]
        imgs = [p.astype(np.float32) for p in img_pts]
        _, K, dist, rvecs, tvecs, std_in, _, _ = cv2.calibrateCameraExtended(
            objs, imgs, image_size, None, None, flags=flags, criteria=criteria
        )
        std = dict(zip(("fx", "fy", "cx", "cy"), map(float, std_in.ravel()[:4])))
        dist = dist.ravel()[: 8 if model == "rational" else 5]
    projected = [project_points(obj, r, t, K, dist, MODEL_LENS[model]) for r, t in zip(rvecs, tvecs)]
    per_view = {s: float(np.sqrt(np.mean(np.sum((p - q) ** 2, axis=1)))) for s, p, q in zip(views, projected, img_pts)}
    return K, dist.astype(np.float64), per_view, std
