"""What a person checks after a run: every warning the stages recorded (each camera's status is sync/status.py's).

Warnings come from where each stage records them:

- calibrate: ``calibration_report.json`` (checkerboard views rejected with
  their reason, ground control points left out as outliers, a camera without
  a pose);
- track: the stage's manifest summary ``warnings`` (a truncated video);
- ingest: ``ingest_report.json`` (fixes dropped per reason, gaps in the log,
  the readers' warnings);
- sync: ``timeline.json`` (per camera ``warnings`` and ``flags``, cameras that
  failed);
- any stage: a ``warnings`` list in its manifest summary, and render's notes.

Pure functions of the parsed files.
"""

from __future__ import annotations

from dataclasses import dataclass

from tlsync_pipeline.sync.status import FLAGS
from tlsync_pipeline.sync.timeline import Timeline


@dataclass(frozen=True)
class StageWarning:
    """One warning: the stage that wrote it, the camera (None: the whole run) and the text."""

    stage: str
    camera: str | None
    text: str


@dataclass(frozen=True)
class StageRun:
    """One stage's last run, from its manifest: stage, camera (None: the project), when (UTC), seconds, its warnings."""

    stage: str
    camera: str | None
    created: str
    seconds: float | None
    warnings: tuple[str, ...] = ()


def calibration_warnings(name: str, report: dict) -> list[StageWarning]:
    """Rejected checkerboard views, GCP outliers and a missing pose, from calibration_report.json."""
    out = []
    intrinsics = report.get("intrinsics") or {}
    for view in intrinsics.get("rejected", []):
        out.append(StageWarning("calibrate", name, f"checkerboard view {view['image']} rejected: {view['reason']}"))
    pose = report.get("pose") or {}
    for point in pose.get("points", []):
        if not point.get("inlier", True):
            out.append(StageWarning("calibrate", name, f"ground control point {point.get('name', '?')} left out as an outlier ({point.get('error_px', float('nan')):.1f} px)"))
    if report.get("warning"):
        out.append(StageWarning("calibrate", name, report["warning"]))
    return out


def ingest_warnings(report: dict) -> list[StageWarning]:
    """Dropped fixes, gaps and the readers' warnings, from ingest_report.json."""
    out = []
    unit = report.get("unit", "line")
    for reason, dropped in (report.get("dropped") or {}).items():
        first = ", ".join(str(n) for n in dropped.get("first", []))
        more = ", ..." if dropped["count"] > len(dropped.get("first", [])) else ""
        out.append(StageWarning("ingest", None, f"{dropped['count']} fix(es) dropped: {reason} ({unit} {first}{more})"))
    for gap in report.get("gaps") or []:
        verdict = "bridged by interpolation" if gap["bridged"] else "not bridged: no target samples there"
        out.append(StageWarning("ingest", None, f"gap of {gap['duration_s']:.2f} s in the log after {gap['after']} ({verdict})"))
    out += [StageWarning("ingest", None, text) for text in report.get("warnings") or []]
    return out


def sync_warnings(timeline: Timeline) -> list[StageWarning]:
    """Per camera: the sync method's warnings and flags, and why failed cameras failed."""
    out = []
    for name, line in timeline.cameras.items():
        out += [StageWarning("sync", name, text) for text in line.warnings or ()]
        out += [StageWarning("sync", name, f"{flag}: {FLAGS[flag][1] if flag in FLAGS else flag}") for flag in line.flags or ()]
    out += [StageWarning("sync", name, f"not synchronized: {why}") for name, why in timeline.failed.items()]
    return out


def gather_warnings(calibration_reports: dict[str, dict], ingest: dict | None, runs: list[StageRun], timeline: Timeline, notes: list[str]) -> list[StageWarning]:
    """Every warning the stages recorded, in stage order, then render's own notes.

    calibration_reports: camera -> its calibration_report.json; ingest: the
    ingest_report.json or None; runs: the stages' last runs (their
    manifests' warnings), in pipeline order; notes: render's own.
    """
    found: list[StageWarning] = []
    for name, report in calibration_reports.items():
        found += calibration_warnings(name, report)
    if ingest:
        found += ingest_warnings(ingest)
    for run in runs:
        if run.stage != "render":
            found += [StageWarning(run.stage, run.camera, text) for text in run.warnings]
    found += sync_warnings(timeline)
    order: dict[str, int] = {}
    for stage in [run.stage for run in runs] + [w.stage for w in found]:
        order.setdefault(stage, len(order))
    found.sort(key=lambda w: order[w.stage] if w.stage != "render" else len(order))
    return found + [StageWarning("render", None, note) for note in notes]
