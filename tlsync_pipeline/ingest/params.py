"""What the ingest stage is asked to do with a log: IngestParams and the rigid transform of a local frame.

A leaf (NumPy only), so that reading a project file does not load the readers or the processing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tlsync_pipeline.geodesy import Origin

DEFAULT_MAX_SPEED_MPS = 60.0


@dataclass(frozen=True)
class RigidTransform:
    """world = R @ local + t (metres): places a local (odometry) frame in the world frame."""

    R: np.ndarray
    t: np.ndarray

    def __post_init__(self) -> None:
        R, t = np.asarray(self.R, dtype=float), np.asarray(self.t, dtype=float)
        if R.shape != (3, 3) or t.shape != (3,) or not (np.isfinite(R).all() and np.isfinite(t).all()):
            raise ValueError("expected R as 3x3 and t as 3 finite numbers")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise ValueError("R is not a rotation matrix (orthonormal, determinant +1)")
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "t", t)

    @classmethod
    def from_yaw(cls, yaw_deg: float, t=(0.0, 0.0, 0.0)) -> RigidTransform:
        """A rotation of yaw_deg about z (counter-clockwise seen from above), then t."""
        c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
        return cls(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.asarray(t, dtype=float))

    def apply(self, xyz: np.ndarray) -> np.ndarray:
        return np.asarray(xyz, dtype=float) @ self.R.T + self.t


@dataclass(frozen=True)
class IngestParams:
    """origin: an Origin or "first" (the first kept fix); rate (Hz) None = the median rate;
    max_gap_s None = 3x the median interval; max_speed_mps None = no spike rejection;
    smoothing_s 0 = none, else the Savitzky-Golay window (s); transform for local logs;
    altitude_reference: what the log's heights are above (one of ALTITUDE_REFERENCES), None =
    as the reader says; altitude_offset_m: added to every height (m) to make it ellipsoidal;
    time_unit, length_unit: seconds per unit of the log's times and metres per unit of its
    local positions or heights (ingest/units.py), applied before anything else."""

    origin: Origin | str = "first"
    rate: float | None = None
    max_gap_s: float | None = None
    max_speed_mps: float | None = DEFAULT_MAX_SPEED_MPS
    smoothing_s: float = 0.0
    transform: RigidTransform | None = None
    altitude_reference: str | None = None
    altitude_offset_m: float = 0.0
    time_unit: float = 1.0
    length_unit: float = 1.0
