"""Commands of the stage graph: run, status and one command per stage.

``tlsync run`` runs what is not fresh; ``tlsync status`` says what is fresh,
stale (and why) or missing; ``tlsync STAGE PROJECT.toml [--camera NAME]``
re-runs one stage (for one camera), after whatever it needs that is not fresh.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from tlsync_pipeline.cli.console import ConsoleProgress
from tlsync_pipeline.cli.exit_codes import ExitCode, exit_code_for
from tlsync_pipeline.cli.json_output import camera_statuses, dumps, status_document
from tlsync_pipeline.errors import EnvironmentProblem, InputError, describe_error, one_line
from tlsync_pipeline.outputs.summary import format_table, format_truth_comparison
from tlsync_pipeline.pipeline.engine import RunSummary, format_status, run_graph, status
from tlsync_pipeline.pipeline.executors import EXECUTORS, SerialExecutor, make_executor
from tlsync_pipeline.pipeline.graph import PER_CAMERA, STAGES, build_graph
from tlsync_pipeline.pipeline.lock import check_writable, running_run
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.sync.timeline import read_timeline, read_truth


def work_option(f):
    f = click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), hidden=True, help="Same as --work.")(f)
    return click.option("--work", "work_dir", type=click.Path(file_okay=False, path_type=Path), help="Work folder (default: work/ beside the project file).")(f)


def executor_options(f):
    f = click.option("--scheduler", help="Dask scheduler address (with --executor dask), e.g. tcp://host:8786.")(f)
    f = click.option("--executor", "executor_kind", type=click.Choice(EXECUTORS), default="process", show_default=True, help="Where per-camera stages run.")(f)
    f = click.option("--jobs", "-j", type=click.IntRange(min=1), help="Worker processes (default: one per core; 1 runs everything in this process).")(f)
    return click.option("--quiet", "-q", is_flag=True, help="No progress messages.")(f)


def resolve_work(project, work_dir: Path | None, out_dir: Path | None) -> Path:
    if work_dir and out_dir and work_dir.resolve() != out_dir.resolve():
        raise InputError("--work and --out name different folders; --out is another name for --work")
    return (work_dir or out_dir or project.default_work_dir).resolve()


def _parse_pairs(value: str | None) -> tuple[tuple[str, str], ...] | None:
    if not value:
        return None
    pairs = []
    for item in value.split(";"):
        names = [n.strip() for n in item.split(",")]
        if len(names) != 2 or not all(names):
            raise InputError(f"--pair {value!r}: expected A,B (several: A,B;A,C)")
        pairs.append((names[0], names[1]))
    return tuple(pairs)


def _parse_frames(value: str | None) -> tuple[int, ...] | None:
    if not value:
        return None
    try:
        return tuple(int(v) for v in value.split(","))
    except ValueError:
        raise InputError(f"--frames {value!r}: expected frame numbers of the second camera, e.g. 120,340,560") from None


def execute(project_file: Path, work_dir, out_dir, *, force_stages=(), cameras=(), targets_stage=None, options=Options(), jobs=None, executor_kind="process", scheduler=None, quiet=False, summary_text=True):
    """Build the graph, run it and print what ran (summary_text: on stdout); returns (graph, summary).

    Stages draw their own progress bars only when they run one at a time in
    this process; tasks in parallel workers get one bar drawn here.
    """
    project = load_project(project_file)
    work = resolve_work(project, work_dir, out_dir)
    _check_camera_option(cameras, [targets_stage] if targets_stage is not None else list(force_stages))
    executor = make_executor(executor_kind, jobs, scheduler)
    stage_bars = not quiet and isinstance(executor, SerialExecutor)
    graph = build_graph(project, work, Options(options.render_pairs, options.render_frames, options.truth, stage_bars))
    for a, b in options.render_pairs or ():
        project.camera(a), project.camera(b)
    force: set[str] = set()
    for stage in force_stages:
        force.update(graph.select(stage, None))
    targets = None
    if targets_stage is not None:
        targets = []
        for camera in cameras or (None,):
            targets += graph.select(targets_stage, camera)
        force.update(targets)
    elif cameras:
        force = {t for t in force if graph.tasks[t].camera in cameras}
    progress = ConsoleProgress(quiet)
    try:
        summary = run_graph(graph, executor, force, targets, progress)
    finally:
        progress.close()
    text = format_summary(summary, counts=not quiet) if summary_text else ""
    if text:
        click.echo(text)
    return graph, summary


def _check_camera_option(cameras, stages: list[str]) -> None:
    """--camera needs a per-camera stage (the stage command's, or --force's with tlsync run)."""
    if not cameras:
        return
    if not stages:
        raise InputError("--camera goes with --force STAGE (tlsync run re-runs only what is not fresh, for every camera)")
    project_wide = [s for s in stages if s not in PER_CAMERA]
    if project_wide:
        raise InputError(f"--camera: the {project_wide[0]} stage is not per camera (it uses every camera); per-camera stages: {', '.join(PER_CAMERA)}")


def format_summary(summary: RunSummary, counts: bool = True) -> str:
    """What ran and was skipped (with counts), then the result messages of the stages that have one."""
    lines = []
    if counts:
        lines.append(f"ran {len(summary.ran)}, fresh {len(summary.fresh)}, failed {len(summary.failed)}, skipped {len(summary.skipped)}")
        if summary.ran:
            lines.append("ran: " + ", ".join(summary.ran))
        lines += [f"skipped {tid}: {why}" for tid, why in summary.skipped.items()]
    lines += [f"{tid}: {summary.results[tid].message}" for tid in summary.ran if summary.results[tid].message]
    return "\n".join(lines)


def report_outcome(summary: RunSummary, quiet: bool = False) -> ExitCode:
    """Print the stages' warnings (unless quiet) and each failure once, on one line; returns the exit code they mean."""
    if not quiet:
        for tid in summary.ran:
            for warning in summary.results[tid].warnings:
                click.echo(f"warning: {tid}: {one_line(warning)}", err=True)
    code = ExitCode.OK
    for tid, error in summary.failed.items():
        click.echo(f"error: {tid}: {describe_error(error)}", err=True)
        code = max(code, exit_code_for(error))
    return ExitCode(code)


def synchronized_code(graph, summary: RunSummary) -> ExitCode:
    """NOT_SYNCHRONIZED when this run's sync stage completed and some camera is not synchronized (ambiguous or failed), else OK."""
    if "sync" in summary.ran + summary.fresh and read_timeline(graph.workspace.path("timeline")).failed:
        return ExitCode.NOT_SYNCHRONIZED
    return ExitCode.OK


def print_timeline(graph, summary: RunSummary, truth: Path | None = None):
    """Print the timeline table (and the comparison with ``truth``) when this run's sync stage completed; returns the Timeline or None."""
    if "sync" not in summary.ran + summary.fresh:
        return None
    timeline = read_timeline(graph.workspace.path("timeline"))
    click.echo("\n" + format_table(timeline))
    if truth is not None:
        pairs, n_frames = read_truth(truth)
        click.echo("\n" + format_truth_comparison(timeline, pairs, n_frames)[0])
    return timeline


@click.command()
@click.argument("project_file", type=click.Path(dir_okay=False, path_type=Path))
@work_option
@click.option("--json", "as_json", is_flag=True, help="Print a JSON document instead (docs/formats.md).")
def status_command(project_file: Path, work_dir: Path | None, out_dir: Path | None, as_json: bool) -> None:
    """Every stage per camera: fresh, stale (and why), missing, failed (and why); 'given' for files the project brings.

    Also the cameras that failed to synchronize and the run in progress, if any.
    Exit code 0 when everything is fresh or given, 1 when something is stale,
    missing or failed, 3 when the work folder cannot be written into.
    """
    project = load_project(project_file)
    work = resolve_work(project, work_dir, out_dir)
    graph = build_graph(project, work)
    rows = status(graph)
    running = running_run(work)
    code = ExitCode.NOT_SYNCHRONIZED if any(r.state not in ("fresh", "given") for r in rows) else ExitCode.OK
    try:
        check_writable(work)
    except EnvironmentProblem as exc:
        problem: EnvironmentProblem | None = exc
        code = ExitCode.ENVIRONMENT
    else:
        problem = None
    if as_json:
        click.echo(dumps(status_document(graph, rows, running, code)))
    else:
        click.echo(f"work folder: {work}")
        if running is not None:
            click.echo(f"run in progress: pid {running['pid']} on {running['host']}, started {running['started']}: {running['command']}")
        click.echo(format_status(rows))
        sync = next((r for r in rows if r.id == "sync"), None)
        for name, camera in camera_statuses(graph, sync is not None and sync.state == "fresh").items():
            click.echo(f"camera {name}: {camera['status']}" + (f": {camera['reason']}" if camera["reason"] else ""))
    if problem is not None:
        click.echo(f"error: {problem}", err=True)
    if code:
        sys.exit(code)


def stage_command(stage: str, help_text: str, render: bool = False) -> click.Command:
    """``tlsync STAGE PROJECT.toml [--camera NAME]``: re-run one stage (what it needs first, if not fresh)."""

    def command(project_file, work_dir, out_dir, camera, jobs, executor_kind, scheduler, quiet, pair=None, frames=None, truth=None):
        options = Options(_parse_pairs(pair), _parse_frames(frames), truth)
        graph, summary = execute(project_file, work_dir, out_dir, cameras=camera, targets_stage=stage, options=options, jobs=jobs, executor_kind=executor_kind, scheduler=scheduler, quiet=quiet)
        code = max(report_outcome(summary, quiet), synchronized_code(graph, summary))
        if code:
            sys.exit(code)

    command.__doc__ = help_text
    command = executor_options(command)
    if render:
        command = click.option("--truth", type=click.Path(dir_okay=False, path_type=Path), help="truth.json: adds pictures at the true relation.")(command)
        command = click.option("--frames", help="Frames of the second camera of each pair to draw, e.g. 120,340.")(command)
        command = click.option("--pair", help="Pairs of cameras to draw: A,B (several: 'A,B;A,C'); default: the first camera with each other.")(command)
    command = click.option("--camera", multiple=True, help="Only this camera (repeatable).")(command)
    command = work_option(command)
    command = click.argument("project_file", type=click.Path(dir_okay=False, path_type=Path))(command)
    return click.command(stage)(command)


intrinsics_command = stage_command("intrinsics", "Re-run the intrinsics stage: checkerboard detection and intrinsics.json per camera.")
calibrate_command = stage_command("calibrate", "Re-run the calibrate stage: the pose; camera.json, calibration_report.json, calibration.png per camera.")
track_command = stage_command("track", "Re-run the track stage: every mover's detections.csv (blob) or the target's track.csv (CSRT) in each camera's video.")
identify_command = stage_command("identify", "Re-run the identify stage: the target among every mover (the init box, if any, seeding it); track.csv and identification.json per camera.")
ingest_command = stage_command("ingest", "Re-run the ingest stage: the [target] log into target/trajectory.csv and ingest_report.json.")
vote_command = stage_command("vote", "Re-run the vote stage: (frame, sample) pairs within eps_px, per camera.")
sync_command = stage_command("sync", "Re-run the sync stage: each camera's line and the timeline (timeline.json).")
export_command = stage_command("export", "Re-run the export stage: frame map, offsets and ffmpeg commands.")
render_command = stage_command("render", "Draw the pictures and charts from cached artefacts, and write report.html and report.md.", render=True)


def run_options(f):
    f = click.option("--camera", multiple=True, help="With --force: force only this camera's stages (repeatable).")(f)
    f = click.option("--force", "force_stages", multiple=True, type=click.Choice(STAGES), help="Re-run this stage even if fresh (repeatable).")(f)
    return executor_options(work_option(f))


def register(group: click.Group) -> None:
    """Add the pipeline's commands to the ``tlsync`` group."""
    group.add_command(status_command, "status")
    for cmd in (intrinsics_command, calibrate_command, track_command, ingest_command, identify_command, vote_command, sync_command, export_command, render_command):
        group.add_command(cmd)
