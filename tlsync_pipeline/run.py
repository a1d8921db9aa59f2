"""Running a project: read its files, synchronize, write timeline.json, report.

The I/O edge around tlsync_pipeline.sync.
"""

from __future__ import annotations

from pathlib import Path

from calibration.camera import read_camera
from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.project import Project
from tlsync_pipeline.sync import CameraInput, CameraResult, synchronize
from tlsync_pipeline.timeline import Relation, Timeline, eps_t, write_timeline
from tlsync_pipeline.trajectory import Trajectory, read_trajectory
from trackers.track import read_track


def load_inputs(project: Project) -> tuple[dict[str, CameraInput], Trajectory]:
    """Every camera's calibration and track, and the target's trajectory."""
    if project.target["trajectory"] is None:
        raise InputError(f"{project.path}: [target]: missing key 'trajectory' (the target's trajectory CSV)")
    cameras = {}
    for spec in project.cameras:
        for key, what in (("camera", "calibration (camera.json)"), ("track", "track (track.csv)")):
            if spec[key] is None:
                raise InputError(f"{project.path}: camera {spec['name']!r}: missing key {key!r}: the camera's {what}")
        camera = read_camera(spec["camera"], name=spec["name"])
        fps = spec["fps"] if spec["fps"] is not None else camera.fps
        cameras[spec["name"]] = CameraInput(camera, read_track(spec["track"]), fps)
    return cameras, read_trajectory(project.target["trajectory"])


def run_project(project: Project, out_dir: Path) -> tuple[Timeline, dict[str, CameraResult]]:
    """Synchronize the project's cameras and write ``out_dir/timeline.json`` atomically."""
    cameras, trajectory = load_inputs(project)
    timeline, results = synchronize(cameras, trajectory, project.sync)
    with atomic_path(out_dir / "timeline.json") as tmp:
        write_timeline(timeline, tmp)
    return timeline, results


def format_table(timeline: Timeline) -> str:
    """The per-camera summary a user reads after a run."""
    rows = [("camera", "alpha", "beta", "votes", "inliers", "start (frames)", "start (s)", "flags")]
    first = timeline.names[0] if timeline.cameras else None
    with_se = False
    for name, line in timeline.cameras.items():
        frames, seconds = timeline.start_offset(first, name)
        alpha, beta = f"{line.alpha:.5f}", f"{line.beta:.2f}"
        start_frames, start_s = f"{frames:+.2f}", "-" if seconds is None else f"{seconds:+.3f}"
        if line.cov is not None:
            with_se = True
            alpha += f" ±{_HALF_95 * line.details['se_alpha']:.2g}"
            beta += f" ±{_HALF_95 * line.details['se_beta']:.2g}"
            se = timeline.start_offset_se(first, name)
            if name != first and se is not None:
                start_frames += f" ±{_HALF_95 * se[0]:.2g}"
                start_s += "" if se[1] is None else f" ±{_HALF_95 * se[1]:.2g}"
        flags = list(line.details.get("flags", [])) + (["fallback"] if line.details.get("warnings") else [])
        rows.append((name, alpha, beta, str(line.votes), str(line.inliers), start_frames, start_s, ",".join(flags) or "-"))
    text = _columns(rows)
    if first is not None:
        text += f"\nstart: when the camera's frame 0 was taken, in frames and seconds of {first} (positive: later than {first}'s frame 0)"
    if with_se:
        text += "\n±: 95 % intervals (1.96 standard errors); flags: few_inliers, ambiguous (a second line with comparable support), along_ray (motion mostly along the viewing ray), fallback (see warnings in timeline.json)"
    for name, line in timeline.cameras.items():
        for warning in line.details.get("warnings", []):
            text += f"\nwarning: {name}: {warning}"
    for name, why in timeline.failed.items():
        text += f"\nnot synchronized: {name}: {why}"
    return text


def format_truth_comparison(timeline: Timeline, truth: dict[str, Relation], n_frames: dict[str, int]) -> tuple[str, dict[str, float]]:
    """Recovered against true pairwise relations, with eps_t per pair (frames of B)."""
    rows = [("pair", "alpha", "true alpha", "beta", "true beta", "eps_t (frames)")]
    errors = {}
    for key, true in truth.items():
        a, b = key.split("->")
        if a not in timeline.cameras or b not in timeline.cameras:
            continue
        estimated = timeline.relation(a, b)
        frames_a = n_frames.get(a) or 1
        errors[key] = eps_t(estimated, true, frames_a)
        rows.append((key, f"{estimated.alpha:.5f}", f"{true.alpha:.5f}", f"{estimated.beta:.2f}", f"{true.beta:.2f}", f"{errors[key]:.3f}"))
    return _columns(rows), errors


_HALF_95 = 1.959964  # normal quantile of a two-sided 95 % interval


def _columns(rows: list[tuple[str, ...]]) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(cell.rjust(w) if i else cell.ljust(w) for i, (cell, w) in enumerate(zip(r, widths))) for r in rows)
