"""The render stage: plots per camera, pictures per pair and report.md, from cached artefacts."""

from __future__ import annotations

from pathlib import Path

from tlsync_pipeline.outputs.pictures import (
    choose_frames,
    default_pairs,
    pair_frames,
    plot_trajectory,
    plot_votes,
    render_pair,
)
from tlsync_pipeline.outputs.summary import format_table
from tlsync_pipeline.pipeline.spec import Sources, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import camera_files, camera_params
from tlsync_pipeline.pipeline.stages.export import frame_count, frame_times
from tlsync_pipeline.pipeline.stages.sync import read_camera_inputs
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.registry import params_from_table
from tlsync_pipeline.sync.synchronize import prepare_trajectory
from tlsync_pipeline.sync.timeline import Timeline, read_timeline, read_truth
from tlsync_pipeline.sync.votes import load_votes
from tlsync_pipeline.trajectory import PiecewiseTrajectory, read_trajectory


def run_render(
    files: StageFiles,
    cameras: list[str],
    fps: dict[str, float | None],
    pairs: list | None = None,
    frames: list | None = None,
    delta: float = 0.5,
) -> dict:
    """The render stage: plots per camera, pictures per pair, report.md.

    Returns the files written and, per pair "A,B", the frames drawn: [frame of B, frame of A].
    """
    tl = read_timeline(files.path("timeline"))
    path_model = PiecewiseTrajectory(prepare_trajectory(read_trajectory(files.path("trajectory")), params_from_table(tl.params)))
    cameras = camera_files(files, cameras, fps)
    inputs = read_camera_inputs({n: c for n, c in cameras.items() if n in tl.cameras})
    times = {name: frame_times(cameras[name], line) for name, line in tl.cameras.items()}
    out_dir = files.output("pictures")
    written: list[Path] = []
    for name, line in tl.cameras.items():
        votes, _ = load_votes(cameras[name]["votes"])
        written.append(plot_votes(name, votes, line, delta, files.output("pictures", f"votes_{name}.png"), times[name]))
        written.append(plot_trajectory(name, inputs[name].camera, inputs[name].track, path_model, line, files.output("pictures", f"trajectory_{name}.png"), times[name]))
    truth_pairs = read_truth(files.path("truth"))[0] if files.has("truth") else None
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
    report = write_report(files, tl, written, notes)
    return {"outputs": [str(p) for p in written], "notes": notes, "report": str(report), "frames": drawn}


def write_report(files: StageFiles, timeline: Timeline, pictures: list[Path], notes: list[str]) -> Path:
    """A short Markdown report of the run: the timeline table, the stages, exports and pictures."""
    lines = ["# tlsync run report", "", "## Timeline", "", "```", format_table(timeline), "```", ""]
    if files.history:
        lines += ["## Stages", "", "| stage | camera | made (UTC) | seconds |", "|---|---|---|---:|"]
        lines += [f"| {m['stage']} | {m['camera'] or '-'} | {m['created']} | {m['seconds']:.1f} |" for m in files.history]
        lines.append("")
    if files.has("offsets") and files.path("offsets").exists():
        lines += ["Exports: [frame map](exports/frame_map.csv), [offsets](exports/offsets.csv), [ffmpeg commands](exports/ffmpeg.sh).", ""]
    calibrations = [files.path(f"calibration_picture:{name}") for name in timeline.names if files.has(f"calibration_picture:{name}")]
    calibrations = [path for path in calibrations if path.exists()]
    work = files.output("report").parent
    lines += ["## Pictures", ""]
    for path in calibrations + list(pictures):
        rel = Path(path).relative_to(work).as_posix()
        title = rel.replace("/", " ").replace(".png", "")
        lines += [f"### {title}", "", f"![{title}]({rel})", ""]
    if notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    with files.write("report") as tmp:
        tmp.write_text("\n".join(lines), encoding="utf-8")
    return files.output("report")


def render_inputs(src: Sources, camera: None) -> dict:
    """What the pictures and the report show: every camera's files and votes, the trajectory, the timeline, the exports."""
    inputs = {"timeline": src.artefact("timeline"), "trajectory": src.artefact("trajectory"), "offsets": src.artefact("offsets")}
    for spec in src.project.cameras:
        name = spec["name"]
        inputs.update({f"{kind}:{name}": src.artefact(kind, name) for kind in ("camera", "track", "votes")})
        if spec.get("video") is not None:
            inputs[f"video:{name}"] = spec["video"]
        if src.made("calibration_picture", name):
            inputs[f"calibration_picture:{name}"] = src.artefact("calibration_picture", name)
    if src.options.truth is not None:
        inputs["truth"] = Path(src.options.truth).resolve()
    return inputs


def render_params(project, camera: None, options) -> dict:
    return {
        **camera_params(project),
        "pairs": [list(p) for p in options.render_pairs] if options.render_pairs else None,
        "frames": list(options.render_frames) if options.render_frames else None,
        "delta": project.sync.delta,
    }


SPEC = StageSpec(
    "render",
    inputs=render_inputs,
    params=render_params,
    outputs=("pictures", "report"),
    run=run_render,
    history=True,
)
