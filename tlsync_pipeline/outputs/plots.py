"""Charts read at a glance: residuals over time per camera, every camera's offset with its interval, recordings that
break (a camera's calibration: outputs/calibration_report.py).

Pure functions: typed values in, PNG bytes out (matplotlib, Agg backend).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tlsync_pipeline.outputs.exports import reference_seconds
from tlsync_pipeline.outputs.figures import png as _png
from tlsync_pipeline.outputs.figures import pyplot as _pyplot
from tlsync_pipeline.outputs.figures import tight_layout
from tlsync_pipeline.sync.model.clock import FrameTimes, Segment
from tlsync_pipeline.sync.model.status import HALF_95, CameraStatus
from tlsync_pipeline.sync.timeline import CameraLine, Timeline
from tlsync_pipeline.trajectory import PiecewiseTrajectory

STATUS_COLOURS = {"ok": "tab:green", "weak": "tab:orange", "ambiguous": "tab:purple", "failed": "tab:red"}


@dataclass(frozen=True)
class Residuals:
    """Tracked minus projected position of one camera at each tracked frame.

    sample: the target sample the camera line assigns to the frame; dx, dy:
    pixels; frames without a projection (outside the log, behind the camera,
    inside a gap) are left out.
    """

    sample: np.ndarray
    dx: np.ndarray
    dy: np.ndarray

    @property
    def distance(self) -> np.ndarray:
        return np.hypot(self.dx, self.dy)


def track_residuals(
    camera, track, path_model: PiecewiseTrajectory, line: CameraLine, times: FrameTimes | None = None
) -> Residuals:
    """Tracked minus projected (px) at every tracked frame, the trajectory model taken at the line's sample.

    times: the camera's presentation times (exact for a presentation-time clock).
    """
    samples = np.atleast_1d(line.sample_at(track.frame, times))
    points = path_model.positions(samples)
    keep = np.isfinite(points[:, 0])
    uv, valid = camera.project(points[keep]) if keep.any() else (np.zeros((0, 2)), np.zeros(0, dtype=bool))
    tracked = track.xy[keep][valid]
    return Residuals(samples[keep][valid], tracked[:, 0] - uv[valid, 0], tracked[:, 1] - uv[valid, 1])


def residuals_plot(residuals: dict[str, Residuals], gate_px: float, seconds_per_sample: float | None) -> bytes:
    """One panel per camera: |tracked - projected| (px) over target time, the vote gate dashed."""
    plt = _pyplot()
    names = list(residuals)
    fig, axes = plt.subplots(
        max(1, len(names)), 1, figsize=(8, 1.2 + 1.6 * max(1, len(names))), sharex=True, squeeze=False
    )
    scale = seconds_per_sample or 1.0
    for ax, name in zip(axes[:, 0], names):
        r = residuals[name]
        d = r.distance
        over = d > gate_px
        ax.plot(r.sample[~over] * scale, d[~over], ".", ms=2.5, c="tab:blue", label="within the gate")
        ax.plot(
            r.sample[over] * scale,
            np.minimum(d[over], 3 * gate_px),
            "^",
            ms=3,
            c="tab:red",
            label="beyond the gate (clipped at 3x)",
        )
        ax.axhline(gate_px, color="k", ls="--", lw=1, label=f"gate {gate_px:g} px")
        ax.set_ylim(0, 3.1 * gate_px)
        median = (
            f"median {np.median(d):.1f} px, {100 * over.mean():.0f} % beyond"
            if len(d)
            else "no tracked frame inside the log"
        )
        ax.set_title(f"{name}: {median}", fontsize=9, loc="left")
        ax.set_ylabel("px")
    axes[0, 0].legend(loc="upper right", fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("target time (s from the log's start)" if seconds_per_sample else "target sample t_r")
    fig.suptitle("tracked minus projected position, per camera", fontsize=10)
    tight_layout(fig)
    return _png(fig)


def offsets_plot(timeline: Timeline, statuses: list[CameraStatus]) -> bytes:
    """Every camera's start against the reference's frame 0 (s, or frames without fps) with its 95 % interval."""
    plt = _pyplot()
    reference = timeline.names[0]
    status = {s.camera: s.status for s in statuses}
    names = timeline.names
    in_seconds = bool(timeline.cameras[reference].fps)
    unit = "s" if in_seconds else "frames"
    fig, ax = plt.subplots(figsize=(8, 0.9 + 0.5 * len(names)))
    for row, name in enumerate(names):
        frames, seconds = timeline.start_offset(reference, name)
        value = seconds if in_seconds else frames
        se = timeline.start_offset_se(reference, name) if name != reference else None
        spread = None if se is None else se[1] if in_seconds else se[0]
        half = None if spread is None else HALF_95 * spread
        colour = STATUS_COLOURS[status.get(name, "ok")]
        ax.errorbar(
            [value], [row], xerr=None if half is None else [[half], [half]], fmt="o", color=colour, capsize=5, ms=5
        )
        text = (
            f"{value:+.3f} {unit}"
            + ("" if half is None else f" ± {half:.2g}")
            + (" (reference)" if name == reference else "")
        )
        ax.annotate(text, (value, row), xytext=(8, 6), textcoords="offset points", fontsize=8)
    ax.set_yticks(range(len(names)), names)
    ax.set_ylim(len(names) - 0.4, -0.6)
    ax.axvline(0, color="0.6", lw=0.8)
    ax.set_xlabel(f"start: when frame 0 was taken, {unit} after {reference}'s frame 0 (bars: 95 % interval)")
    ax.margins(x=0.25)
    tight_layout(fig)
    return _png(fig)


def recordings_plot(timeline: Timeline, n_frames: dict[str, int], times: dict[str, FrameTimes | None]) -> bytes:
    """Every synchronized camera's recording on the reference's clock (s, or its frames without fps): a bar per
    segment of known offset (sync/identify/segments.py), each break of the recording marked where it happened, with its
    kind
    and size (trackers/breaks.py)."""
    plt = _pyplot()
    reference = timeline.names[0]
    in_seconds = bool(timeline.cameras[reference].fps)
    names = timeline.names
    fig, ax = plt.subplots(figsize=(8, 0.9 + 0.6 * len(names)))

    def at(name: str, frames) -> np.ndarray:
        matched = timeline.match(name, reference, np.asarray(frames, dtype=np.float64), times)
        return np.array([reference_seconds(timeline, f, times) for f in matched]) if in_seconds else matched

    for row, name in enumerate(names):
        line = timeline.cameras[name]
        count = n_frames[name]
        for seg in line.clock.segments or (Segment(0, count, 0.0, "line"),):
            first, last = max(seg.start, 0), min(seg.stop, count) - 1
            if seg.shift is None or last < first:
                continue
            start, end = at(name, [first, last + 0.49])  # the segment holds frames up to stop - 0.5
            ax.barh(row, end - start, left=start, height=0.35, color="tab:blue" if seg.source == "line" else "tab:cyan")
        for b in line.breaks or ():
            where = at(name, [max(b.frame, 0)])[0]
            if not np.isfinite(where):
                where = at(name, [max(b.frame - 1, 0)])[0]
            if np.isfinite(where):
                ax.plot([where], [row - 0.3], marker="v", color="tab:red", ms=7)
                ax.annotate(
                    b.describe(),
                    (where, row - 0.3),
                    xytext=(4, 4),
                    textcoords="offset points",
                    fontsize=7,
                    color="tab:red",
                )
    ax.set_yticks(range(len(names)), names)
    ax.set_ylim(len(names) - 0.4, -0.9)
    ax.set_xlabel(
        f"{'s' if in_seconds else 'frames'} of {reference}'s clock (bars: segments of known offset; red: breaks)"
    )
    tight_layout(fig)
    return _png(fig)
