"""Text a person reads after a run: the per-camera table, the comparison with a truth, a
camera's calibration in one line."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tlsync_pipeline.sync.model.status import OK
from tlsync_pipeline.sync.timeline import Relation, Timeline, eps_t


def format_table(timeline: Timeline) -> str:
    """The per-camera summary a user reads after a run: each camera's status (sync/model/status.py), its line, its
    start.
    """
    rows = [("camera", "status", "alpha", "beta", "votes", "inliers", "start (frames)", "start (s)")]
    first = timeline.names[0] if timeline.cameras else ""
    with_se = False
    status = timeline.statuses()
    for name, line in timeline.cameras.items():
        frames, seconds = timeline.start_offset(first, name)
        alpha, beta = f"{line.alpha:.5f}", f"{line.beta:.2f}"
        start_frames = f"{frames:+.2f}" if np.isfinite(frames) else "-"  # frame 0 in a segment of unknown offset: none
        start_s = "-" if seconds is None or not np.isfinite(seconds) else f"{seconds:+.3f}"
        if line.se_alpha is not None and line.se_beta is not None:
            with_se = True
            alpha += f" ±{_HALF_95 * line.se_alpha:.2g}"
            beta += f" ±{_HALF_95 * line.se_beta:.2g}"
            se = timeline.start_offset_se(first, name)
            if name != first and se is not None:
                start_frames += f" ±{_HALF_95 * se[0]:.2g}"
                start_s += "" if se[1] is None else f" ±{_HALF_95 * se[1]:.2g}"
        state = status[name].status + (f": {len(line.clock.segments)} segments" if line.clock.segments else "")
        rows.append((name, state, alpha, beta, str(line.votes), str(line.inliers), start_frames, start_s))
    for name in timeline.failed:
        rows.append((name, status[name].status, "-", "-", "-", "-", "-", "-"))
    text = _columns(rows)
    if first:
        text += (
            f"\nstart: when the camera's frame 0 was taken, in frames and seconds of {first} (positive: later "
            f"than {first}'s frame 0)"
        )
    if with_se:
        text += "\n±: 95 % intervals (1.96 standard errors)"
    text += "\nstatus: ok, weak (synchronized, for the reason given), ambiguous or failed (not synchronized)"
    if timeline.cameras:
        text += (
            "\nframes away from the target's visits map only if the recording runs on unbroken there: a break that "
            "neither the container's times nor the pictures show is not seen (docs/accuracy.md)"
        )
    vfr = [name for name, line in timeline.cameras.items() if line.clock.vfr]
    if vfr:
        text += (
            f"\nvariable frame rate: {', '.join(vfr)}: starts in frames are approximate; exports/frame_map.csv "
            f"maps frames exactly"
        )
    for camera in status.values():
        if camera.status != OK:
            text += f"\n{camera.camera}: {camera.status}: {camera.reason}" + (
                f" (what to do: {camera.remedy})" if camera.remedy else ""
            )
    return text


def format_truth_comparison(
    timeline: Timeline, truth: dict[str, Relation], n_frames: dict[str, int]
) -> tuple[str, dict[str, float]]:
    """Recovered against true pairwise relations, with eps_t per pair (frames of B); a pair with a camera that was
    not synchronized is a row that says so (no eps_t)."""
    rows = [("pair", "alpha", "true alpha", "beta", "true beta", "eps_t (frames)")]
    errors = {}
    for key, true in truth.items():
        a, b = key.split("->")
        missing = [name for name in (a, b) if name not in timeline.cameras]
        if missing:
            rows.append(
                (
                    key,
                    "-",
                    f"{true.alpha:.5f}",
                    "-",
                    f"{true.beta:.2f}",
                    f"failed: {', '.join(missing)} not synchronized",
                )
            )
            continue
        estimated = timeline.relation(a, b)
        frames_a = n_frames.get(a) or 1
        errors[key] = eps_t(estimated, true, frames_a)
        rows.append(
            (
                key,
                f"{estimated.alpha:.5f}",
                f"{true.alpha:.5f}",
                f"{estimated.beta:.2f}",
                f"{true.beta:.2f}",
                f"{errors[key]:.3f}",
            )
        )
    return _columns(rows), errors


_HALF_95 = 1.959964  # normal quantile of a two-sided 95 % interval


def _columns(rows: Sequence[Sequence[str]]) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join(
        "  ".join(cell.rjust(w) if i else cell.ljust(w) for i, (cell, w) in enumerate(zip(r, widths))) for r in rows
    )
