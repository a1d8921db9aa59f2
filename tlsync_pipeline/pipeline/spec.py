"""How a stage declares itself: its input files, typed parameters, artefacts and function, once.

Each module under ``pipeline/stages/`` defines one ``SPEC``. The graph makes
one task of it per camera (``per_camera``) or one for the project; the task's
cache key and its call both come from the same declaration:

    inputs(sources, camera)          -> {label: project file (Path) or Artefact}   hashed; StageFiles.path(label)
    params(project, camera, options) -> the stage's parameters (a frozen dataclass) in the key; run(files, params)
    outputs                          artefact kinds written (for the task's camera)
    run(files, params)               does the work, writes only through ``files``; returns a StageResult

The parameters hold exactly what the stage reads, so that a key another
stage reads does not make this one stale; their JSON form (``params_json``)
is what the cache key and the manifest hold.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from tlsync_pipeline.pipeline.workspace import Artefact

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project
    from tlsync_pipeline.pipeline.workspace import StageFiles


@dataclass(frozen=True)
class Options:
    """How a run shows itself: whether stages draw their progress bars."""

    progress: bool = True


@dataclass(frozen=True)
class StageResult:
    """What a stage's run returns, the same for every stage.

    message: one line for the terminal (what was written); warnings: for
    users, one per line, under the stage that raised them; failed: cameras
    this run could not serve (camera -> why; a per-camera stage names its
    own camera); outputs: files written inside a folder artefact (render's
    pictures), hashed into the manifest; facts: JSON values the manifest
    records (counts, frames drawn); worker_cpu_s: CPU seconds its parts used
    in the run's workers (executors.run_each).
    """

    message: str | None = None
    warnings: tuple[str, ...] = ()
    failed: Mapping[str, str] = field(default_factory=dict)
    outputs: tuple[Path, ...] = ()
    facts: Mapping[str, Any] = field(default_factory=dict)
    worker_cpu_s: float = 0.0

    def record(self) -> dict[str, Any]:
        """The manifest's ``summary``: message, warnings, failed cameras and facts (JSON)."""
        return {"message": self.message, "warnings": list(self.warnings), "failed": dict(self.failed), **self.facts}


class Sources(Protocol):
    """Where a task's input comes from: an artefact another task makes, or the file the project brings."""

    project: Project
    options: Options

    def artefact(self, kind: str, camera: str | None = None) -> Path | Artefact:
        """The artefact if a task makes it, else the project's file; InputError naming what to give when neither."""
        ...

    def made(self, kind: str, camera: str | None = None) -> bool:
        """Whether a task of this project makes that artefact."""
        ...


@dataclass(frozen=True)
class StageSpec:
    """One stage, declared once (see the module's docstring)."""

    name: str
    inputs: Callable[[Sources, Any], dict[str, Path | Artefact]]
    params: Callable[[Project, Any, Options], Any]
    outputs: tuple[str, ...]
    run: Callable[[StageFiles, Any], StageResult]
    per_camera: bool = False
    # A per-camera stage of about a second: it runs in the calling process while the run's workers are not up
    # (starting a worker costs more: it imports the pipeline), on the workers once a longer task started them.
    light: bool = False
    # A per-camera stage whose cost grows with its input files (decoding video): its tasks are handed out
    # first, the largest inputs first, so that the longest task does not start last and leave a worker alone.
    heavy: bool = False
    applies: Callable[[Project, Any], bool] = lambda project, camera: True  # does the project need this task?
    # The task gets the last runs of the tasks it needs (StageFiles.history: their warnings, when, how long);
    # their warnings are part of its cache key.
    history: bool = False
    # Runs for the other cameras when a camera's own tasks did not complete: its params (a ProjectWide)
    # then leave that camera out and name it with why (ProjectWide.leaving_out).
    runs_without_failed_cameras: bool = False


@dataclass(frozen=True)
class ProjectWide:
    """Parameters of a project-wide stage that runs without the cameras whose own tasks did not complete.

    cameras: the cameras it serves, in project order; left_out: camera -> why it was left out.
    """

    cameras: tuple[str, ...]
    left_out: Mapping[str, str] = field(default_factory=dict)

    def leaving_out(self, reasons: Mapping[str, str]) -> ProjectWide:
        return dataclasses.replace(
            self, cameras=tuple(n for n in self.cameras if n not in reasons), left_out={**self.left_out, **reasons}
        )


def params_json(value: Any) -> Any:
    """A stage's parameters as JSON values (dataclasses as objects, arrays as lists); paths stay paths
    (Workspace.portable).
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: params_json(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): params_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [params_json(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value
