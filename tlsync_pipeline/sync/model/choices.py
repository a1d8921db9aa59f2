"""Sync choices and defaults a project file may name, without the sync's libraries (a leaf: no OpenCV, no SciPy)."""

from __future__ import annotations

SCAN_MODES = ("auto", "full")  # [track] scan: the coarse pass over keyframes first, or every frame read
GCP_SIGMA_M = 1.0  # default survey quality of GCPs (metres per coordinate): read off a web map or walked with a phone
