"""How a stage declares itself: its input files, parameters, artefacts and function, once.

Each module under ``pipeline/stages/`` defines one ``SPEC``. The graph makes
one task of it per camera (``per_camera``) or one for the project; the task's
cache key and its call both come from the same declaration:

    inputs(sources, camera)  -> {label: project file (Path) or Artefact}   hashed; StageFiles.path(label)
    params(project, camera, options) -> {name: JSON value}                  in the key; run(files, **params)
    outputs                   artefact kinds written (for the task's camera)
    run(files, **params)      does the work, writes only through ``files``; returns a JSON-able summary
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from tlsync_pipeline.pipeline.workspace import Artefact

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


@dataclass(frozen=True)
class Options:
    """Run options that are stage parameters (they enter the cache keys), and whether to show progress."""

    render_pairs: tuple[tuple[str, str], ...] | None = None
    render_frames: tuple[int, ...] | None = None
    truth: Path | None = None
    progress: bool = True


class Sources(Protocol):
    """Where a task's input comes from: an artefact another task makes, or the file the project brings."""

    project: Project
    options: Options

    def artefact(self, kind: str, camera: str | None = None) -> Path | Artefact:
        """The artefact if a task makes it, else the project's file; InputError naming what to give when neither."""

    def made(self, kind: str, camera: str | None = None) -> bool:
        """Whether a task of this project makes that artefact."""


@dataclass(frozen=True)
class StageSpec:
    """One stage, declared once (see the module's docstring)."""

    name: str
    inputs: Callable[[Sources, str | None], dict[str, Path | Artefact]]
    params: Callable[[Project, str | None, Options], dict[str, Any]]
    outputs: tuple[str, ...]
    run: Callable[..., dict]
    per_camera: bool = False
    # A per-camera stage of about a second: it runs in the calling process while the run's workers are not up
    # (starting a worker costs more: it imports the pipeline), on the workers once a longer task started them.
    light: bool = False
    applies: Callable[[Project, str | None], bool] = lambda project, camera: True  # does the project need this task?
    history: bool = False  # the task gets the earlier runs' records (StageFiles.history)
    # Runs for the other cameras when a camera's own tasks did not complete: its params' ``cameras``
    # list drops that camera, and run gets ``left_out`` (camera -> why); see Task.leaving_out.
    runs_without_failed_cameras: bool = False
