"""The trackers' kinds, without their libraries: what a project file or ``--tracker`` may name (a leaf: no OpenCV, no
PyAV).
"""

from __future__ import annotations

KINDS = ("blob", "csrt")
DEFAULT_KIND = KINDS[0]
