"""The work folder: where each artefact lives (artefacts/kinds.py), atomic writes, and what a running stage may touch.

Layout (relative to the work folder; docs/pipeline.md lists it for users):

    cameras/<cam>/intrinsics.json, intrinsics_report.json          intrinsics
    cameras/<cam>/camera.json, calibration_report.json, calibration.png   calibrate
    cameras/<cam>/track.csv, cameras/<cam>/video.json               track
    cameras/<cam>/clock.json                                        clock
    cameras/<cam>/votes.npz                                         vote
    target/trajectory.csv, target/ingest_report.json                ingest
    timeline.json                                                   sync
    exports/frame_map.csv, offsets.csv, ffmpeg.sh                   export
    exports/timeline.otio, timeline.fcpxml, sync.json               export (editors' timelines)
    render/*.png, render/proxy/<cam>.mp4, report.html, report.md    render
    <folder of the stage's artefacts>/<stage>.manifest.json         the cache's record of a run
    .lock, .hashes.json                                             the running tlsync, remembered hashes

A stage gets a ``StageFiles``: the paths of the inputs it declared and the
artefacts it declared, nothing else. With strict checking on (the
``TLSYNC_STRICT_IO`` environment variable; the tests set it), opening a file
of the work or project folder that the stage did not declare raises
``UndeclaredFileError``.
"""

from __future__ import annotations

import contextvars
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tlsync_pipeline.artefacts.kinds import FOLDERS, artefact_path
from tlsync_pipeline.atomic import atomic_path

if TYPE_CHECKING:
    from tlsync_pipeline.outputs.diagnostics import StageRun

# Where a project-wide stage's manifest lives (per-camera stages: the camera's folder; others: the work folder).
_MANIFEST_FOLDERS = {"ingest": "target", "export": "exports", "render": "render"}
WORK_PREFIX = "<work>/"
STRICT_VARIABLE = "TLSYNC_STRICT_IO"


@dataclass(frozen=True)
class Artefact:
    """A file a stage makes in the work folder: its kind (a key of artefacts.kinds.KINDS) and camera (None:
    project-wide).
    """

    kind: str
    camera: str | None = None

    @property
    def rel(self) -> str:
        """Its path relative to the work folder (POSIX)."""
        return artefact_path(self.kind, self.camera)


class UndeclaredFileError(RuntimeError):
    """A stage opened a file of the work or project folder it did not declare (a bug in the stage's spec)."""


class Workspace:
    """The one owner of a project's work folder layout."""

    def __init__(self, work: Path, root: Path):
        self.work = Path(work).resolve()
        self.root = Path(root).resolve()

    def path(self, kind: str, camera: str | None = None) -> Path:
        """Absolute path of one artefact."""
        return self.work / Artefact(kind, camera).rel

    def manifest(self, stage: str, camera: str | None) -> Path:
        """The manifest of one stage run, beside its artefacts."""
        folder = f"cameras/{camera}" if camera is not None else _MANIFEST_FOLDERS.get(stage, "")
        return self.work / folder / f"{stage}.manifest.json"

    @property
    def hash_memo(self) -> Path:
        return self.work / ".hashes.json"

    def resolve(self, source: Path | Artefact) -> Path:
        """Absolute path of a project file or an artefact."""
        return self.work / source.rel if isinstance(source, Artefact) else Path(source)

    def portable(self, value: Any) -> Any:
        """``value`` with every path made relative: artefacts as ``<work>/...``, other files to the project folder.

        What the cache keys and manifests hold, so that a project moved or
        copied to another folder (with its work folder) keeps its keys.
        """
        if isinstance(value, Artefact):
            return WORK_PREFIX + value.rel
        if isinstance(value, Path):
            path = value if value.is_absolute() else self.root / value
            if path.is_relative_to(self.work):
                return WORK_PREFIX + path.relative_to(self.work).as_posix()
            return Path(os.path.relpath(path, self.root)).as_posix()
        if isinstance(value, dict):
            return {k: self.portable(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [self.portable(v) for v in value]
        return value

    def files(
        self, task: str, camera: str | None, inputs: dict[str, Path | Artefact], outputs: list[Artefact], **context
    ) -> StageFiles:
        """The view of one task: its inputs (label -> absolute path) and its artefacts (kind -> absolute path)."""
        return StageFiles(
            task,
            camera,
            {label: self.resolve(source) for label, source in inputs.items()},
            {a.kind: self.resolve(a) for a in outputs},
            (self.work, self.root),
            **context,
        )


@dataclass
class StageFiles:
    """What one running task may read (its declared inputs) and write (its declared artefacts).

    It travels to worker processes (plain paths). ``progress`` and ``cores``
    are how the caller wants the task run: progress bars or not, how many
    processes the task may start itself (1 inside a pool's worker).
    ``workers``: the run's executor, for a task running in the engine's
    process that hands independent parts of its work to the run's workers
    (executors.run_each); None in a worker (no pool inside a pool).
    """

    task: str
    camera: str | None
    inputs: dict[str, Path]
    outputs: dict[str, Path]
    guarded: tuple[Path, ...]  # folders whose files must be declared to be opened (work, project)
    progress: bool = True
    cores: int = 1
    history: list[StageRun] = field(default_factory=list)  # the needed tasks' last runs, in pipeline order
    workers: Any = field(default=None, repr=False, compare=False)

    @property
    def camera_name(self) -> str:
        """The task's camera (a per-camera stage's)."""
        if self.camera is None:
            raise ValueError(f"{self.task}: not a per-camera task")
        return self.camera

    def path(self, label: str) -> Path:
        """A declared input's path."""
        try:
            return self.inputs[label]
        except KeyError:
            raise UndeclaredFileError(
                f"{self.task}: input {label!r} is not declared (declared: {', '.join(self.inputs) or 'none'})"
            ) from None

    def has(self, label: str) -> bool:
        return label in self.inputs

    def output(self, kind: str, name: str | None = None) -> Path:
        """A declared artefact's path (``name``: a file in a folder artefact, or None: the folder), for writers that
        write atomically themselves.
        """
        try:
            path = self.outputs[kind]
        except KeyError:
            raise UndeclaredFileError(
                f"{self.task}: artefact {kind!r} is not declared (declared: {', '.join(self.outputs) or 'none'})"
            ) from None
        if name is not None and kind not in FOLDERS:
            raise ValueError(f"{self.task}: artefact {kind!r} is a file, not a folder")
        return path / name if name is not None else path

    @contextmanager
    def write(self, kind: str, name: str | None = None) -> Iterator[Path]:
        """Write a declared artefact atomically: yields a temporary path renamed into place on success."""
        with atomic_path(self.output(kind, name)) as tmp:
            yield tmp

    @contextmanager
    def running(self) -> Iterator[StageFiles]:
        """Checks the files the task opens while it runs, when strict checking is on."""
        if not os.environ.get(STRICT_VARIABLE):
            yield self
            return
        _install_audit_hook()
        token = _RUNNING.set(self)
        try:
            yield self
        finally:
            _RUNNING.reset(token)

    def check_open(self, path: str, writing: bool) -> None:
        """UndeclaredFileError when ``path`` lies in the work or project folder and the task did not declare it."""
        path = os.path.abspath(path)
        if not any(path.startswith(str(folder) + os.sep) for folder in self.guarded):
            return
        if path.endswith(".manifest.json") and not writing:
            return  # the cache's records, not artefacts
        for output in self.outputs.values():
            out = str(output)
            if path == out or path.startswith(out + os.sep):
                return
            head, name = os.path.split(out)
            if os.path.dirname(path) == head and os.path.basename(path).startswith(f".{name}."):
                return  # the temporary file of an atomic write
        if not writing and path in {str(p) for p in self.inputs.values()}:
            return
        raise UndeclaredFileError(
            f"{self.task}: opened {path} for {'writing' if writing else 'reading'} without declaring it"
        )


_RUNNING: contextvars.ContextVar[StageFiles | None] = contextvars.ContextVar("tlsync_running_stage", default=None)
_HOOK_INSTALLED = False


def _audit(event: str, args: tuple) -> None:
    if event != "open":
        return
    files = _RUNNING.get()
    if files is None or not isinstance(args[0], (str, bytes, os.PathLike)):
        return
    path, mode, flags = args
    writing = (
        any(c in mode for c in "wax+")
        if isinstance(mode, str)
        else bool(flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT))
    )
    files.check_open(os.fsdecode(path), writing)


def _install_audit_hook() -> None:
    global _HOOK_INSTALLED
    if not _HOOK_INSTALLED:
        sys.addaudithook(_audit)
        _HOOK_INSTALLED = True
