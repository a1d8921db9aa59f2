"""The timing a pose from the target gives its camera's line, kept with the pose.

A pose fitted to the target's track fits a line with it (sync/pose/pose.py's
TargetPose): synchronize() gives that line to the camera it poses itself
(``with_pose_line``, ``with_pose_offset`` in sync/solve/synchronize.py).
When the calibrate stage poses the camera, the sync stage gets the same from
calibration_report.json's ``target_pose.timing`` (``to_dict``,
``from_dict``), so that a project run through the stages gets the line
synchronize() gives on the same inputs.

Clock units (frames, or presentation time x fps): frame = alpha * sample + beta.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from tlsync_pipeline.errors import InputError


@dataclass(frozen=True, eq=False)
class PoseTiming:
    """The pose fit's line (alpha, beta), its (2, 2) covariance for the timing (TargetPose.line_cov; None: not
    finite), its beta std (clock units, TargetPose.se_beta), under a log with a bias the beta the pose and the log's
    bias explain best (NaN otherwise) and the spread of the pose fits that are one timing with it (clock units)."""

    alpha: float
    beta: float
    cov: np.ndarray | None
    se_beta: float
    bias_beta: float = float("nan")
    spread: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (null for NaN and a missing covariance)."""
        return {
            "alpha": self.alpha,
            "beta": self.beta,
            "cov": None if self.cov is None else np.asarray(self.cov, dtype=np.float64).tolist(),
            "se_beta": _finite_or_none(self.se_beta),
            "bias_beta": _finite_or_none(self.bias_beta),
            "spread": self.spread,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str) -> PoseTiming:
        """The timing ``to_dict`` wrote; InputError naming ``source`` when it is not that."""
        try:
            cov = None if data.get("cov") is None else np.asarray(data["cov"], dtype=np.float64).reshape(2, 2)
            return cls(
                float(data["alpha"]),
                float(data["beta"]),
                cov,
                _nan_if_none(data.get("se_beta")),
                _nan_if_none(data.get("bias_beta")),
                float(data.get("spread", 0.0)),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{source}: target_pose.timing is not a pose's timing ({exc})") from None


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _nan_if_none(value: Any) -> float:
    return float("nan") if value is None else float(value)
