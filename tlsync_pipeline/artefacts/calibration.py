"""intrinsics_report.json (intrinsics stage -> calibrate) and calibration_report.json (calibrate stage -> render).

Their content is the calibration's report as docs/calibration.md describes
it (per-view errors, detected corners, rejected views; the pose's points and
uncertainty; the pose from the target): a JSON document made by the
calibration code and read by outputs/summary.py and outputs/plots.py.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tlsync_pipeline.artefacts.jsonfile import read_document, write_document


@dataclass(frozen=True)
class IntrinsicsReport:
    """intrinsics_report.json: the ``intrinsics`` part of calibration_report.json (docs/calibration.md)."""

    content: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class CalibrationReport:
    """calibration_report.json: ``camera``, ``intrinsics``, ``pose`` and, for a pose from the target, ``target_pose``
    (docs/calibration.md)."""

    content: Mapping[str, Any] = field(default_factory=dict)


def write_intrinsics_report(report: IntrinsicsReport, path: str | Path) -> None:
    write_document(report.content, path)


def read_intrinsics_report(path: str | Path) -> IntrinsicsReport:
    return IntrinsicsReport(read_document(path, "an intrinsics report"))


def write_calibration_report(report: CalibrationReport, path: str | Path) -> None:
    write_document(report.content, path)


def read_calibration_report(path: str | Path) -> CalibrationReport:
    return CalibrationReport(read_document(path, "a calibration report"))
