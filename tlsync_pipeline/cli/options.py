"""The options several ``tlsync`` commands share, declared once so that each has one name and one meaning.

- ``PROJECT``: a project file, or a folder holding one (``load_project``);
- ``--work DIR``: the work folder (default ``work/`` beside the project file);
- ``-o, --out FILE``: the file a standalone command writes (never a folder);
- ``--camera NAME``: only this camera's per-camera stages (repeatable);
- ``-j, --jobs N``: processes; ``--executor``, ``--scheduler``: where per-camera stages run;
- ``-q, --quiet``: no progress, counts nor warnings (results and errors are still printed);
- ``-v, --verbose``: an error's details (and a traceback for an unexpected one) under its line.

docs/cli.md lists them, and where tlsync differs from COLMAP's and DVC's habits.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click

from tlsync_pipeline.pipeline.executors import EXECUTORS

VERBOSE = "tlsync.verbose"  # key of click's context meta (shared by a command and the group around it)

Decorator = Callable[[Callable], Callable]


def in_order(*decorators: Decorator) -> Decorator:
    """The decorators applied so that ``--help`` lists their options in the order given."""

    def apply(f: Callable) -> Callable:
        for decorate in reversed(decorators):
            f = decorate(f)
        return f

    return apply


def project_argument(f: Callable) -> Callable:
    return click.argument("project", metavar="PROJECT", type=click.Path(path_type=Path))(f)


def work_option(f: Callable) -> Callable:
    return in_order(
        click.option(
            "--work",
            "work_dir",
            type=click.Path(file_okay=False, path_type=Path),
            metavar="DIR",
            help="Work folder (default: work/ beside the project file).",
        ),
        _refused(
            "--out",
            "names the file a standalone command writes (ingest-log, track-video, calibrate-intrinsics); the work "
            "folder is --work DIR",
        ),
    )(f)


def out_option(what: str) -> Decorator:
    """``-o, --out FILE``: the file the command writes (``what`` says which)."""
    return click.option("--out", "-o", "out", required=True, type=click.Path(dir_okay=False, path_type=Path), help=what)


def camera_option(help_text: str = "Only this camera's stages (repeatable).") -> Decorator:
    return click.option("--camera", multiple=True, metavar="NAME", help=help_text)


def jobs_option(f: Callable) -> Callable:
    return click.option(
        "--jobs",
        "-j",
        type=click.IntRange(min=1),
        metavar="N",
        help="Processes (default: one per core; 1 runs everything in this process).",
    )(f)


def executor_options(f: Callable) -> Callable:
    return in_order(
        jobs_option,
        click.option(
            "--executor",
            "executor_kind",
            type=click.Choice(EXECUTORS),
            default="process",
            show_default=True,
            help="Where per-camera stages run.",
        ),
        click.option(
            "--scheduler",
            metavar="ADDRESS",
            help="Dask scheduler address (with --executor dask), e.g. tcp://host:8786.",
        ),
    )(f)


def quiet_option(
    help_text: str = "No progress, counts nor warnings (results and errors are still printed).",
) -> Decorator:
    return click.option("--quiet", "-q", is_flag=True, help=help_text)


def verbose_option(f: Callable) -> Callable:
    """``-v, --verbose``: read with ``verbose()``; not passed to the command."""

    def remember(ctx: click.Context, param: click.Parameter, value: bool) -> bool:
        if value:
            ctx.meta[VERBOSE] = True
        return value

    return click.option(
        "--verbose",
        "-v",
        is_flag=True,
        expose_value=False,
        callback=remember,
        help="An error's details under its line.",
    )(f)


def verbose() -> bool:
    """Whether the running command was given --verbose."""
    ctx = click.get_current_context(silent=True)
    return bool(ctx and ctx.meta.get(VERBOSE))


def _refused(name: str, why: str) -> Decorator:
    """A hidden option that stops with ``why`` (an option of another command, or with another meaning)."""

    def refuse(ctx: click.Context, param: click.Parameter, value: object) -> None:
        if value:
            raise click.UsageError(f"{name}: {why}", ctx)

    return click.option(name, hidden=True, expose_value=False, callback=refuse, multiple=True)


def refused_camera(stage: str, per_camera: tuple[str, ...]) -> Decorator:
    """``--camera`` on a project-wide stage's command: refused, saying why."""
    return _refused(
        "--camera",
        f"the {stage} stage uses every camera; --camera goes with run and the per-camera stages "
        f"({', '.join(per_camera)})",
    )
