"""The ``tlsync`` command line: parses arguments, calls the pipeline, maps errors to exit codes.

Exit codes: 0 success, 1 a camera could not be synchronized, 2 bad input.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from tlsync_pipeline.cli import pipeline as pipeline_cli
from tlsync_pipeline.cli.demo import demo as demo_command
from tlsync_pipeline.cli.pipeline import execute, finish, run_options
from tlsync_pipeline.errors import INPUT_ERRORS, SyncError
from tlsync_pipeline.outputs.summary import format_table, format_truth_comparison
from tlsync_pipeline.sync.timeline import read_timeline, read_truth

EXIT_SYNC_FAILED = 1
EXIT_BAD_INPUT = 2


class TlsyncGroup(click.Group):
    """Turns tlsync's errors into a one-line message and an exit code."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except INPUT_ERRORS as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except SyncError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(EXIT_SYNC_FAILED)


@click.group(cls=TlsyncGroup)
@click.version_option(package_name="tlsync")
def main() -> None:
    """Temporal alignment of fixed, non-overlapping cameras from a logged target trajectory."""


@main.command()
@click.argument("project_file", type=click.Path(path_type=Path))
@run_options
@click.option("--truth", type=click.Path(dir_okay=False, path_type=Path), help="A truth.json to compare against (prints eps_t per pair).")
def run(project_file: Path, work_dir: Path | None, out_dir: Path | None, truth: Path | None, force_stages, camera, jobs, executor_kind, scheduler, quiet) -> None:
    """Run every stage of PROJECT_FILE that is not fresh; write timeline.json, exports, pictures."""
    graph, summary = execute(project_file, work_dir, out_dir, force_stages=force_stages, cameras=camera, jobs=jobs, executor_kind=executor_kind, scheduler=scheduler, quiet=quiet)
    finish(summary)
    timeline = read_timeline(graph.workspace.path("timeline"))
    click.echo("\n" + format_table(timeline))
    if truth is not None:
        pairs, n_frames = read_truth(truth)
        click.echo("\n" + format_truth_comparison(timeline, pairs, n_frames)[0])
    click.echo(f"\nwrote {graph.workspace.path('timeline')}, {graph.workspace.path('report_html')}")
    if timeline.failed:
        sys.exit(EXIT_SYNC_FAILED)


pipeline_cli.register(main)  # run, status and one command per stage (calibrate, ingest, ...), through the cache
main.add_command(demo_command)

from tlsync_pipeline.cli.calibrate import calibrate_intrinsics  # noqa: E402
from tlsync_pipeline.cli.ingest import ingest_log_command  # noqa: E402
from tlsync_pipeline.cli.track import track_video_command  # noqa: E402

main.add_command(calibrate_intrinsics)
main.add_command(ingest_log_command)
main.add_command(track_video_command)
