"""The calibration's choices and defaults, without its libraries: what a project file may name, checked at once.

A leaf module (it imports no OpenCV), so that parsing a project file stays quick.
"""

from __future__ import annotations

from calibration.errors import CalibrationInputError

MODEL_LENS = {"standard": "opencv", "rational": "opencv", "fisheye": "fisheye"}  # intrinsics model -> lens model
MODELS = tuple(MODEL_LENS)
MAX_FRAMES = 60  # frames of a checkerboard video used at most
MAX_VIEW_ERROR = 1.0  # px: a view whose RMS reprojection error exceeds this is dropped
RANSAC_PX = 8.0  # px: the GCP pose's RANSAC inlier threshold


def parse_corners(text: str) -> tuple[int, int]:
    """``"7x6"`` -> (7, 6): inner corners, columns x rows; CalibrationInputError when not a board."""
    parts = str(text).lower().replace(" ", "").split("x")
    try:
        cols, rows = (int(p) for p in parts)
    except ValueError:
        raise CalibrationInputError(
            f"expected inner corners as COLSxROWS (e.g. 7x6 for a board of 8x7 squares), got {text!r}"
        ) from None
    if cols < 2 or rows < 2 or cols * rows < 6:
        raise CalibrationInputError(f"a checkerboard needs at least 2x3 inner corners, got {text!r}")
    return cols, rows
