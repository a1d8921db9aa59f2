"""The ``tlsync`` command line: parses arguments, calls the pipeline, maps errors to exit codes.

Exit codes: see tlsync_pipeline.cli.exit_codes (the README's table). SIGTERM
stops a command as Ctrl-C does.
"""

from __future__ import annotations

import signal
import sys
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import NoReturn

import click

from tlsync_pipeline.cli import pipeline as pipeline_cli
from tlsync_pipeline.cli.console import print_error, shown, usage_error_text
from tlsync_pipeline.cli.demo import demo as demo_command
from tlsync_pipeline.cli.exit_codes import ExitCode, exit_code_for
from tlsync_pipeline.cli.json_output import dumps, run_document
from tlsync_pipeline.cli.options import in_order, project_argument, quiet_option, verbose_option
from tlsync_pipeline.cli.pipeline import execute, print_timeline, report_outcome, run_options, synchronized_code
from tlsync_pipeline.cli.signals import INTERRUPTED_MESSAGE, interrupt
from tlsync_pipeline.errors import INPUT_ERRORS, EnvironmentProblem, SyncError, describe_error
from tlsync_pipeline.pipeline.stop import clear as clear_stop
from tlsync_pipeline.pipeline.stop import stop_requested


class TlsyncGroup(click.Group):
    """Turns every error, tlsync's and click's (a usage error), into one ``error:`` line and an exit code; SIGTERM into
    Ctrl-C.
    """

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.exceptions.NoArgsIsHelpError as exc:  # ``tlsync`` alone: the help, as ``tlsync --help`` prints it
            click.echo(exc.ctx.get_help() if exc.ctx is not None else exc.format_message())
            sys.exit(0)
        except click.ClickException as exc:
            print_error(usage_error_text(exc))
            sys.exit(exc.exit_code)
        except click.Abort:
            click.echo(INTERRUPTED_MESSAGE, err=True)
            sys.exit(ExitCode.INTERRUPTED)
        sys.exit(code if isinstance(code, int) else 0)

    def invoke(self, ctx):
        try:
            if stop_requested():  # asked while the command line loaded: an import may have swallowed the interrupt
                raise KeyboardInterrupt
            with _terminate_as_interrupt():
                done = super().invoke(ctx)
            if stop_requested():  # asked meanwhile, where Python could not raise it (``__main__._unraisable``)
                raise KeyboardInterrupt
            return done
        except KeyboardInterrupt:
            _stopped()
        except (*INPUT_ERRORS, EnvironmentProblem, SyncError, OSError) as exc:
            if stop_requested():  # what the interrupt left behind (a file closed under a stopped task)
                _stopped()
            print_error(describe_error(exc), exc)
            sys.exit(exit_code_for(exc))
        except Exception:
            # A KeyboardInterrupt raised inside an extension's import comes out as another error (pybind11:
            # "ImportError: initialization failed"): with a stop asked, it is the stop, not a failure.
            if stop_requested():
                _stopped()
            raise
        finally:
            clear_stop()  # a stop asked of this command is not the next one's in this process (as tests run them)


def _stopped() -> NoReturn:
    """The one line and exit code 130 of a command stopped by Ctrl-C or SIGTERM."""
    click.echo(INTERRUPTED_MESSAGE, err=True)
    sys.exit(ExitCode.INTERRUPTED)


@contextmanager
def _terminate_as_interrupt():
    """While a command runs, SIGTERM raises KeyboardInterrupt as Ctrl-C does (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@click.group(cls=TlsyncGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="tlsync")
def main() -> None:
    """Temporal alignment of fixed, non-overlapping cameras from a logged target trajectory."""


@main.command()
@in_order(
    project_argument,
    run_options,
    click.option(
        "--truth",
        type=click.Path(dir_okay=False, path_type=Path),
        help="A truth.json to compare against (prints eps_t per pair).",
    ),
    click.option(
        "--json",
        "as_json",
        is_flag=True,
        help="Print a JSON summary of the run on stdout instead of the tables (docs/formats.md).",
    ),
    quiet_option(),
    verbose_option,
)
def run(
    project: Path,
    work_dir: Path | None,
    truth: Path | None,
    as_json: bool,
    force_stages,
    camera,
    jobs,
    executor_kind,
    scheduler,
    quiet,
) -> None:
    """Run every stage of PROJECT that is not fresh; write timeline.json, exports, pictures.

    PROJECT is the project file, or the folder that holds it (project.toml).
    """
    graph, summary = execute(
        project,
        work_dir,
        force_stages=force_stages,
        cameras=camera,
        jobs=jobs,
        executor_kind=executor_kind,
        scheduler=scheduler,
        quiet=quiet,
        summary_text=not as_json,
    )
    code = max(report_outcome(graph, summary, quiet), synchronized_code(graph, summary))
    if as_json:
        click.echo(dumps(run_document(graph, summary, code)))
    else:
        timeline = print_timeline(graph, summary, truth)
        if timeline is not None:
            click.echo(
                shown(
                    f"\nwrote {graph.workspace.path('timeline')}"
                    + (f", {graph.workspace.path('report_html')}" if "render" in summary.ran + summary.fresh else "")
                )
            )
        elif camera and not quiet:
            click.echo("sync, export and render use every camera: run without --camera to bring them up to date")
    if code:
        sys.exit(code)


pipeline_cli.register(main)  # run, status and one command per stage (calibrate, ingest, ...), through the cache
main.add_command(demo_command)

from tlsync_pipeline.cli.calibrate import calibrate_intrinsics  # noqa: E402
from tlsync_pipeline.cli.ingest import ingest_log_command  # noqa: E402
from tlsync_pipeline.cli.track import track_video_command  # noqa: E402

main.add_command(calibrate_intrinsics)
main.add_command(ingest_log_command)
main.add_command(track_video_command)
