"""What the run's report holds, shared by report.html and report.md.

Pictures carry their file beside the report (``href``, relative to the work
folder) and, for the self-contained HTML, their bytes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from tlsync_pipeline.outputs.diagnostics import StageRun
from tlsync_pipeline.sync.model.status import HALF_95, CameraStatus
from tlsync_pipeline.sync.timeline import ErrorBudget, StageWarning, Timeline


@dataclass(frozen=True)
class Picture:
    """A picture: its title, its path relative to the work folder, the bytes to embed (None: link
    only) and their type.
    """

    title: str
    href: str
    data: bytes | None = None
    caption: str = ""
    media_type: str = "image/png"


@dataclass(frozen=True)
class ReportContent:
    """Everything the report shows (see report_html and report_md)."""

    title: str
    timeline: Timeline
    statuses: list[CameraStatus]
    warnings: list[StageWarning]
    stages: list[StageRun]
    calibration: dict[str, str] = field(default_factory=dict)  # camera -> one-line summary
    ingest: str | None = None  # the ingest summary text
    charts: list[Picture] = field(default_factory=list)
    camera_pictures: dict[str, list[Picture]] = field(default_factory=dict)
    pair_pictures: list[Picture] = field(default_factory=list)
    calibration_pictures: list[Picture] = field(default_factory=list)
    exports: list[tuple[str, str]] = field(default_factory=list)  # (label, path relative to the work folder)
    notes: dict[str, list[str]] = field(
        default_factory=dict
    )  # section ("pictures", "exports") -> what was not drawn or written, and why
    player: dict | None = None  # player.player_data


@dataclass(frozen=True)
class CameraRow:
    """One camera's line in the report's table, as text."""

    camera: str
    status: str
    reason: str
    remedy: str  # what to do about the worst reason ("" when ok)
    start: str  # when its frame 0 was taken, after the reference's, with the 95 % interval
    relation: str  # frame = a x reference frame + b, with 95 % intervals
    clock: str  # CFR / VFR and the rate
    support: str  # inliers / votes
    budget: str = "-"  # where its timing uncertainty comes from: shares of the variance (tracking, calibration, log)


def camera_rows(timeline: Timeline, statuses: list[CameraStatus]) -> list[CameraRow]:
    """The per-camera table: status, start and relation to the reference with 95 % intervals, clock."""
    reference = timeline.names[0] if timeline.cameras else ""
    rows = []
    for status in statuses:
        name = status.camera
        if name not in timeline.cameras:
            rows.append(CameraRow(name, status.status, status.reason, status.remedy, "-", "-", "-", "-"))
            continue
        line = timeline.cameras[name]
        frames, seconds = timeline.start_offset(reference, name)
        se = timeline.start_offset_se(reference, name) if name != reference else None
        if name == reference:
            start, relation = "0 (reference)", "reference"
        else:
            start = f"{seconds:+.3f} s" if seconds is not None else f"{frames:+.2f} frames of {reference}"
            spread = None if se is None else se[0] if seconds is None else se[1]
            if spread is not None:
                start += f" ± {HALF_95 * spread:.2g}"
            rel = timeline.relation(reference, name)
            cov = timeline.relation_cov(reference, name)
            a = f"{rel.alpha:.5f}" + ("" if cov is None else f" ± {HALF_95 * cov[0, 0] ** 0.5:.2g}")
            b = f"{rel.beta:+.2f}" + ("" if cov is None else f" ± {HALF_95 * cov[1, 1] ** 0.5:.2g}")
            relation = f"frame = {a} × frame of {reference} {b}"
        vfr = line.clock.vfr
        fps = line.clock.fps if vfr else line.fps
        if vfr and name != reference:
            relation += " (linear approximation; exact matches in frame_map.csv)"
        clock = ("VFR (presentation times)" if vfr else "CFR (frame indices)") + (f", {fps:.3f} fps" if fps else "")
        rows.append(
            CameraRow(
                name,
                status.status,
                status.reason,
                status.remedy,
                start,
                relation,
                clock,
                f"{line.inliers} / {line.votes}",
                budget_text(line.budget),
            )
        )
    return rows


def budget_text(budget: ErrorBudget | None) -> str:
    """ "± 1.2 frames: tracking 10 %, calibration 30 %, log 60 %" (the camera's own 1-sigma, and shares of its
    variance), or "-".
    """
    if budget is None or not budget.total_frames > 0:
        return "-"
    parts = {"tracking": budget.tracking_frames, "calibration": budget.calibration_frames, "log": budget.log_frames}
    shares = ", ".join(f"{k} {100 * v**2 / budget.total_frames**2:.0f} %" for k, v in parts.items())
    return f"± {budget.total_frames:.2g} frames: {shares}"
