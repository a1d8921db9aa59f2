"""Commands of the stage graph: run, status and one command per stage.

``tlsync run`` runs what is not fresh; ``tlsync status`` says what is fresh,
stale (and why) or missing; ``tlsync STAGE PROJECT.toml [--camera NAME]``
re-runs one stage (for one camera), after whatever it needs that is not fresh.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from tlsync_pipeline.cli.console import ConsoleProgress, print_error, shown
from tlsync_pipeline.cli.exit_codes import ExitCode, exit_code_for
from tlsync_pipeline.cli.json_output import camera_statuses, dumps, status_document
from tlsync_pipeline.cli.options import (
    camera_option,
    executor_options,
    in_order,
    project_argument,
    quiet_option,
    refused_camera,
    verbose_option,
    work_option,
)
from tlsync_pipeline.errors import EnvironmentProblem, InputError, describe_error, one_line
from tlsync_pipeline.outputs.summary import format_table, format_truth_comparison
from tlsync_pipeline.pipeline.executors import SerialExecutor, make_executor
from tlsync_pipeline.pipeline.lock import WorkLock, check_writable, running_run
from tlsync_pipeline.pipeline.stage_names import PER_CAMERA, STAGES
from tlsync_pipeline.sync.timeline import read_timeline, read_truth

if TYPE_CHECKING:  # the engine, the graph and the project load with the command that runs them (a quick --help)
    from tlsync_pipeline.pipeline.engine import RunSummary
    from tlsync_pipeline.pipeline.graph import Graph


def resolve_work(project, work_dir: Path | None) -> Path:
    """The work folder: --work, else work/ beside the project file."""
    return (work_dir or project.default_work_dir).resolve()


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


def execute(
    project_file: Path,
    work_dir: Path | None,
    *,
    force_stages=(),
    cameras=(),
    targets_stage=None,
    force_target=True,
    jobs=None,
    executor_kind="process",
    scheduler=None,
    quiet=False,
    summary_text=True,
):
    """Build the graph, run it and print what ran (summary_text: on stdout); returns (graph, summary).

    targets_stage: run that stage's tasks and what they need, nothing after
    them (force_target: even when fresh). cameras: only these cameras'
    per-camera tasks (those of ``targets_stage`` when given), with what they
    need first; forced stages only for them.
    Stages draw their own progress bars only when they run one at a time in
    this process; tasks in parallel workers get one bar drawn here.
    """
    from tlsync_pipeline.pipeline.engine import run_graph
    from tlsync_pipeline.pipeline.graph import build_graph, worker_modules
    from tlsync_pipeline.pipeline.project import load_project
    from tlsync_pipeline.pipeline.spec import Options

    project = load_project(project_file)
    work = resolve_work(project, work_dir)
    for name in cameras:
        project.camera(name)
    _check_force_with_cameras(cameras, force_stages)
    executor = make_executor(executor_kind, jobs, scheduler, worker_modules())
    try:
        stage_bars = not quiet and isinstance(executor, SerialExecutor)
        graph = build_graph(project, work, Options(progress=stage_bars))
        force: set[str] = set()
        for stage in force_stages:
            force.update(graph.select(stage, None))
        targets = None
        if targets_stage is not None:
            targets = [tid for camera in cameras or (None,) for tid in graph.select(targets_stage, camera)]
            if force_target:
                force.update(targets)
        elif cameras:
            targets = [tid for tid, task in graph.tasks.items() if task.camera in cameras]
        if cameras:
            force = {t for t in force if graph.tasks[t].camera in cameras}
        progress = ConsoleProgress(quiet)
        try:
            summary = run_graph(graph, executor, force, targets, progress)
        finally:
            progress.close()
    finally:
        executor.close()  # closed by the run already; not when refused first (its idle fork server ends here)
    text = format_summary(summary, counts=not quiet) if summary_text else ""
    if text:
        click.echo(text)
    return graph, summary


def _check_force_with_cameras(cameras, force_stages) -> None:
    """--camera restricts --force to per-camera stages: a project-wide one would be left out."""
    project_wide = [s for s in force_stages if s not in PER_CAMERA]
    if cameras and project_wide:
        raise InputError(
            f"--force {project_wide[0]} --camera: the {project_wide[0]} stage is not per camera (it uses every "
            f"camera); per-camera stages: {', '.join(PER_CAMERA)}"
        )


def format_summary(summary: RunSummary, counts: bool = True) -> str:
    """What ran and was skipped (with counts), then the result messages of the stages that have one."""
    lines = []
    if counts:
        lines.append(
            f"ran {len(summary.ran)}, fresh {len(summary.fresh)}, failed {len(summary.failed)}, skipped "
            f"{len(summary.skipped)}"
        )
        if summary.ran:
            lines.append("ran: " + ", ".join(summary.ran))
        lines += [f"skipped {tid}: {why}" for tid, why in summary.skipped.items()]
    lines += [f"{tid}: {summary.results[tid].message}" for tid in summary.ran if summary.results[tid].message]
    return shown("\n".join(lines))


def report_outcome(graph: Graph, summary: RunSummary, quiet: bool = False) -> ExitCode:
    """Print the run's warnings (unless quiet) and each failure once, on one line; returns the exit code they mean.

    The warnings of the tasks that ran, grouped by task in pipeline order
    (at most WARNINGS_PER_TASK each), then how many the run has in all, the
    fresh tasks' included: the list report.html and timeline.json hold.
    """
    if not quiet:
        print_warnings(graph, summary)
    code = ExitCode.OK
    for tid, error in summary.failed.items():
        print_error(describe_error(error), error, where=tid)
        code = max(code, exit_code_for(error))
    return ExitCode(code)


WARNINGS_PER_TASK = 5  # warning lines printed per task (the rest counted; the report lists them all)


def print_warnings(graph: Graph, summary: RunSummary) -> None:
    """``warning: TASK: text`` per warning of the tasks that ran, then ``N warnings (see report.html)`` (stderr)."""
    total = sum(len(w) for w in summary.warnings.values())
    if not total:
        return
    printed = 0
    for tid in graph.tasks:
        if tid not in summary.ran:
            continue
        texts = summary.warnings.get(tid, ())
        for text in texts[:WARNINGS_PER_TASK]:
            click.echo(f"warning: {tid}: {shown(one_line(text))}", err=True)
        if len(texts) > WARNINGS_PER_TASK:
            click.echo(f"warning: {tid}: ... and {len(texts) - WARNINGS_PER_TASK} more like these", err=True)
        printed += len(texts)
    line = f"{total} warning{'s' if total > 1 else ''}"
    if printed < total:
        line += f" ({total - printed} from stages that did not run again)" if printed else ""
    if "render" in summary.ran + summary.fresh:
        line += f"; see {shown(str(graph.workspace.path('report_html')))}"
    click.echo(line, err=True)


def synchronized_code(graph, summary: RunSummary) -> ExitCode:
    """NOT_SYNCHRONIZED when this run's sync stage completed and some camera is not synchronized (ambiguous or failed),
    else OK.
    """
    if "sync" in summary.ran + summary.fresh and read_timeline(graph.workspace.path("timeline")).failed:
        return ExitCode.NOT_SYNCHRONIZED
    return ExitCode.OK


def print_timeline(graph, summary: RunSummary, truth: Path | None = None):
    """Print the timeline table (and the comparison with ``truth``) when this run's sync stage completed; returns the
    Timeline or None.
    """
    if "sync" not in summary.ran + summary.fresh:
        return None
    timeline = read_timeline(graph.workspace.path("timeline"))
    click.echo("\n" + format_table(timeline))
    if truth is not None:
        pairs, n_frames = read_truth(truth)
        click.echo("\n" + format_truth_comparison(timeline, pairs, n_frames)[0])
    return timeline


@click.command()
@in_order(
    project_argument,
    work_option,
    click.option("--json", "as_json", is_flag=True, help="Print a JSON document instead (docs/formats.md)."),
    quiet_option("Print nothing: the exit code says whether everything is fresh."),
    verbose_option,
)
def status_command(project: Path, work_dir: Path | None, as_json: bool, quiet: bool) -> None:
    """Every stage per camera: fresh, stale (and why), missing, failed (and why); 'given' for files the project brings.

    Also the cameras that failed to synchronize and the run in progress, if any.
    Exit code 0 when everything is fresh or given, 1 when something is stale,
    missing or failed, 3 when the work folder cannot be written into. Reads
    only: it creates no folder and no file.
    """
    from tlsync_pipeline.pipeline.engine import format_status, status
    from tlsync_pipeline.pipeline.graph import build_graph
    from tlsync_pipeline.pipeline.project import load_project

    loaded = load_project(project)
    work = resolve_work(loaded, work_dir)
    graph = build_graph(loaded, work)
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
    elif not quiet:
        click.echo(f"work folder: {work}" + ("" if work.is_dir() else " (not made yet)"))
        if running is not None:
            click.echo(
                f"run in progress: pid {running['pid']} on {running['host']}, started {running['started']}: "
                f"{running['command']}"
            )
        click.echo(format_status(rows))
        sync = next((r for r in rows if r.id == "sync"), None)
        for name, camera in camera_statuses(graph, sync is not None and sync.state == "fresh").items():
            click.echo(f"camera {name}: {camera['status']}" + (f": {camera['reason']}" if camera["reason"] else ""))
    if problem is not None:
        print_error(str(problem), problem)
    if code:
        sys.exit(code)


def stage_command(stage: str, help_text: str, render: bool = False) -> click.Command:
    """``tlsync STAGE PROJECT [--camera NAME]``: re-run one stage (what it needs first, if not fresh)."""

    def command(
        project, work_dir, jobs, executor_kind, scheduler, quiet, camera=(), pair=None, frames=None, truth=None
    ):
        from tlsync_pipeline.pipeline.engine import task_files
        from tlsync_pipeline.pipeline.project import load_project
        from tlsync_pipeline.pipeline.stages.render import draw_requested
        from tlsync_pipeline.pipeline.strip_requests import StripRequest

        request = (
            StripRequest(_parse_pairs(pair), _parse_frames(frames), read_truth(truth)[0] if truth else None)
            if pair or frames or truth
            else None
        )
        if request is not None and request.pairs:
            loaded = load_project(project)
            for name in {n for p in request.pairs for n in p}:
                loaded.camera(name)
        graph, summary = execute(
            project,
            work_dir,
            cameras=camera,
            targets_stage=stage,
            force_target=request is None,
            jobs=jobs,
            executor_kind=executor_kind,
            scheduler=scheduler,
            quiet=quiet,
        )
        code = max(report_outcome(graph, summary, quiet), synchronized_code(graph, summary))
        if request is not None and stage in summary.ran + summary.fresh:
            task = graph.tasks[stage]
            with WorkLock(graph.work):
                written = draw_requested(task_files(graph, stage), task.params, request)
            click.echo("wrote " + ", ".join(shown(str(path)) for path in written))
        if code:
            sys.exit(code)

    command.__doc__ = help_text
    render_options = (
        click.option(
            "--pair",
            metavar="A,B",
            help="Draw the strip of matching frames of cameras A and B (several: 'A,B;A,C'), kept beside the other "
            "pictures as render/pair_A_B....png.",
        ),
        click.option(
            "--frames",
            metavar="F,F",
            help="Frames of the second camera of each pair to draw, e.g. 120,340 (default: chosen; without --pair: "
            "the default pairs).",
        ),
        click.option(
            "--truth",
            type=click.Path(dir_okay=False, path_type=Path),
            help="truth.json: the strips show A's true match too.",
        ),
    )
    camera = (
        camera_option("Only this camera (repeatable).") if stage in PER_CAMERA else refused_camera(stage, PER_CAMERA)
    )
    command = in_order(
        project_argument,
        work_option,
        camera,
        *(render_options if render else ()),
        executor_options,
        quiet_option(),
        verbose_option,
    )(command)
    return click.command(stage)(command)


intrinsics_command = stage_command(
    "intrinsics", "Re-run the intrinsics stage: checkerboard detection and intrinsics.json per camera."
)
calibrate_command = stage_command(
    "calibrate",
    "Re-run the calibrate stage: the pose; camera.json, calibration_report.json, calibration.png per camera.",
)
track_command = stage_command(
    "track",
    "Re-run the track stage: every mover's detections.csv (blob) or the target's track.csv (CSRT) in each camera's "
    "video.",
)
clock_command = stage_command(
    "clock",
    "Re-run the clock stage: each camera's recording time (its video's metadata or [cameras.clock] recorded) into "
    "clock.json.",
)
identify_command = stage_command(
    "identify",
    "Re-run the identify stage: the target among every mover (the init box, if any, seeding it); track.csv and "
    "identification.json per camera.",
)
ingest_command = stage_command(
    "ingest", "Re-run the ingest stage: the [target] log into target/trajectory.csv and ingest_report.json."
)
vote_command = stage_command("vote", "Re-run the vote stage: (frame, sample) pairs within eps_px, per camera.")
sync_command = stage_command("sync", "Re-run the sync stage: each camera's line and the timeline (timeline.json).")
export_command = stage_command("export", "Re-run the export stage: frame map, offsets and ffmpeg commands.")
render_command = stage_command(
    "render", "Draw the pictures and charts from cached artefacts, and write report.html and report.md.", render=True
)


def run_options(f):
    """run's options before --truth and --json: --work, --camera, --force, the executor's."""
    return in_order(
        work_option,
        camera_option(
            "Only this camera's per-camera stages, with what they need (repeatable); sync, export and render use "
            "every camera and wait for a run without --camera."
        ),
        click.option(
            "--force",
            "force_stages",
            multiple=True,
            type=click.Choice(STAGES),
            metavar="STAGE",
            help=f"Re-run this stage even if fresh (repeatable; with --camera, for that camera): {', '.join(STAGES)}.",
        ),
        executor_options,
    )(f)


def register(group: click.Group) -> None:
    """Add the pipeline's commands to the ``tlsync`` group."""
    group.add_command(status_command, "status")
    for cmd in (
        intrinsics_command,
        calibrate_command,
        track_command,
        clock_command,
        ingest_command,
        identify_command,
        vote_command,
        sync_command,
        export_command,
        render_command,
    ):
        group.add_command(cmd)
