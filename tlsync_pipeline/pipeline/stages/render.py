"""The render stage: plots per camera, pictures per pair and report.md, from cached artefacts."""

from __future__ import annotations

from pathlib import Path

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.outputs.pictures import (
    choose_frames,
    default_pairs,
    pair_frames,
    plot_trajectory,
    plot_votes,
    render_pair,
)
from tlsync_pipeline.outputs.summary import format_table
from tlsync_pipeline.pipeline import layout
from tlsync_pipeline.pipeline.cache import read_manifest
from tlsync_pipeline.pipeline.stages import STAGES
from tlsync_pipeline.pipeline.stages.export import frame_count, frame_times
from tlsync_pipeline.pipeline.stages.sync import read_camera_inputs
from tlsync_pipeline.sync.registry import params_from_table
from tlsync_pipeline.sync.synchronize import prepare_trajectory
from tlsync_pipeline.sync.timeline import Timeline, read_timeline, read_truth
from tlsync_pipeline.sync.votes import load_votes
from tlsync_pipeline.trajectory import PiecewiseTrajectory, read_trajectory


def run_render(
    cameras: dict[str, dict],
    trajectory: Path,
    timeline: Path,
    work: Path,
    truth: Path | None = None,
    pairs: list | None = None,
    frames: list | None = None,
    delta: float = 0.5,
) -> dict:
    """The render stage: plots per camera, pictures per pair, report.md.

    Returns the files written and, per pair "A,B", the frames drawn: [frame of B, frame of A].
    """
    tl = read_timeline(timeline)
    path_model = PiecewiseTrajectory(prepare_trajectory(read_trajectory(trajectory), params_from_table(tl.params)))
    inputs = read_camera_inputs({n: c for n, c in cameras.items() if n in tl.cameras})
    times = {name: frame_times(cameras[name], line) for name, line in tl.cameras.items()}
    out_dir = layout.render_dir(work)
    written: list[Path] = []
    for name, line in tl.cameras.items():
        votes, _ = load_votes(cameras[name]["votes"])
        written.append(plot_votes(name, votes, line, delta, out_dir / f"votes_{name}.png", times[name]))
        written.append(plot_trajectory(name, inputs[name].camera, inputs[name].track, path_model, line, out_dir / f"trajectory_{name}.png", times[name]))
    truth_pairs = read_truth(truth)[0] if truth else None
    videos = {n: Path(c["video"]) for n, c in cameras.items() if c.get("video") and n in tl.cameras}
    pair_list = [tuple(p) for p in pairs] if pairs else default_pairs(tl)
    notes = []
    drawn = {}
    for a, b in pair_list:
        if a not in videos or b not in videos:
            notes.append(f"{a}, {b}: no band-swap or strip pictures (needs both cameras' videos)")
            continue
        n_frames = {a: frame_count(cameras[a]), b: frame_count(cameras[b])}
        chosen = list(frames) if frames else choose_frames(inputs[b].track.frame, lambda f: tl.match(b, a, f, times), n_frames[a], n_frames[b])
        made = render_pair(a, b, chosen, tl, inputs, path_model, videos, n_frames, truth_pairs, out_dir, times)
        if not made:
            notes.append(f"{a}, {b}: the two videos never record at the same time")
        else:
            drawn[f"{a},{b}"] = [[f, fa] for f, fa in pair_frames(a, b, chosen, tl, times).items()]
        written += made
    report = write_report(tl, work, written, notes)
    return {"outputs": [str(p) for p in written], "notes": notes, "report": str(report), "frames": drawn}


def write_report(timeline: Timeline, work: Path, pictures: list[Path], notes: list[str]) -> Path:
    """A short Markdown report of the run: the timeline table, the stages, exports and pictures."""
    lines = ["# tlsync run report", "", "## Timeline", "", "```", format_table(timeline), "```", ""]
    manifests = [m for m in (read_manifest(p) for p in work.rglob("*.manifest.json")) if m is not None]
    manifests.sort(key=lambda m: (STAGES.index(m.stage) if m.stage in STAGES else len(STAGES), m.camera or ""))
    if manifests:
        lines += ["## Stages", "", "| stage | camera | made (UTC) | seconds |", "|---|---|---|---:|"]
        lines += [f"| {m.stage} | {m.camera or '-'} | {m.created} | {m.seconds:.1f} |" for m in manifests]
        lines.append("")
    if layout.offsets_csv(work).exists():
        lines += ["Exports: [frame map](exports/frame_map.csv), [offsets](exports/offsets.csv), [ffmpeg commands](exports/ffmpeg.sh).", ""]
    calibrations = [layout.calibration_picture(work, name) for name in timeline.names if layout.calibration_picture(work, name).exists()]
    lines += ["## Pictures", ""]
    for path in calibrations + list(pictures):
        rel = Path(path).relative_to(work).as_posix()
        title = rel.replace("/", " ").replace(".png", "")
        lines += [f"### {title}", "", f"![{title}]({rel})", ""]
    if notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    path = layout.report_md(work)
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines), encoding="utf-8")
    return path
