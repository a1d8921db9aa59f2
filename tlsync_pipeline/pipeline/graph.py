"""The tasks a project makes of the stage specs.

intrinsics -> clock -> ingest -> scan -> track -> calibrate -> identify -> vote -> sync -> export -> render
(calibrate after track and ingest: a camera whose pose comes from the target reads its track, or
every mover, and the trajectory; scan, the coarse pass over a long recording, takes its pose from
the camera.json the project brings or from the GCPs or board alone).
A task is one stage for one camera (or the project). Everything about it
comes from its stage's SPEC (pipeline/spec.py): the files it reads (hashed
for its cache key), its parameters, the artefacts it writes, and the function
called with them. Its dependencies are the tasks that make its input
artefacts. A file the user brings in the project file (``camera = ...``,
``track = ...``, ``detections = ...``, ``[target] trajectory = ...``) takes
the place of the artefact, and the stage that would make it has no task. A
camera with every mover (detections) gets its track.csv from the identify
stage, which later in the stage order takes that artefact over.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.pipeline.project import Project
from tlsync_pipeline.pipeline.spec import Options, StageSpec
from tlsync_pipeline.pipeline.stage_names import PER_CAMERA, STAGES
from tlsync_pipeline.pipeline.stages import (
    calibrate,
    clock,
    export,
    identify,
    ingest,
    intrinsics,
    render,
    scan,
    sync,
    track,
    vote,
)
from tlsync_pipeline.pipeline.workspace import Artefact, Workspace

STAGE_SPECS: dict[str, StageSpec] = {
    s.name: s
    for s in (
        intrinsics.SPEC,
        clock.SPEC,
        ingest.SPEC,
        scan.SPEC,
        track.SPEC,
        calibrate.SPEC,
        identify.SPEC,
        vote.SPEC,
        sync.SPEC,
        export.SPEC,
        render.SPEC,
    )
}
assert STAGES == tuple(STAGE_SPECS) and PER_CAMERA == tuple(n for n, s in STAGE_SPECS.items() if s.per_camera), (
    "stage_names.py lists STAGE_SPECS"
)
LAZY_LIBRARIES = (  # imported by the stages only where they need them: pictures, videos, splines, geodetic files
    "av",
    "cv2",
    "matplotlib.pyplot",
    "pyproj",
    "scipy.interpolate",
)
COMPILED = ("trackers.fork_preload",)  # the blob detector's compiled passes (numba), loaded at their import


def worker_modules() -> tuple[str, ...]:
    """What a run's local workers import before their first task (ProcessExecutor's preload): every stage's module
    (render's draws each camera on them), the libraries the stages import lazily and the detector's compiled
    passes."""
    return (*sorted({spec.run.__module__ for spec in STAGE_SPECS.values()}), *LAZY_LIBRARIES, *COMPILED)


# Artefact kind -> the stage that first makes it (a camera's track.csv: the track stage, or identify for every mover).
MAKER: dict[str, str] = {}
for _spec in STAGE_SPECS.values():
    for _kind in _spec.outputs:
        MAKER.setdefault(_kind, _spec.name)


@dataclass(frozen=True)
class _Givable:
    """An artefact a project may bring instead of a stage making it: the file the project names (camera None:
    [target]), and what to say when neither is there (pipeline/validate.py checks the file before any stage runs)."""

    given: Callable[[Project, Any], Path | None]
    missing: str


_GIVEN = {
    "camera": _Givable(
        lambda p, cam: p.camera(cam).camera,
        "give 'camera' (a camera.json) or a [cameras.calibration] table to calibrate it from",
    ),
    "track": _Givable(
        lambda p, cam: p.camera(cam).track, "give 'track' (a track.csv) or 'video' (to track the target in)"
    ),
    "detections": _Givable(
        lambda p, cam: p.camera(cam).detections,
        "give 'detections' (a detections.csv) or 'video' (to detect every mover in)",
    ),
    "trajectory": _Givable(
        lambda p, cam: p.target.trajectory,
        "give 'log' (a GPS or odometry log to ingest) or 'trajectory' (a metric trajectory CSV)",
    ),
}


@dataclass
class Task:
    """One stage for one camera (camera None: the whole project)."""

    spec: StageSpec
    camera: str | None
    inputs: dict[str, Path | Artefact]
    params: Any  # the stage's parameters (StageSpec.params); None when the task cannot run
    outputs: list[Artefact]
    deps: list[str]
    problem: str | None = None  # why it cannot run (an input the project does not say how to make)

    @property
    def stage(self) -> str:
        return self.spec.name

    @property
    def id(self) -> str:
        return task_id(self.stage, self.camera)

    def leaving_out(self, reasons: dict[str, str], incomplete: list[str]) -> Task:
        """This task without the cameras in ``reasons`` (camera -> why) and the ``incomplete`` tasks it waited for.

        For a stage that runs without failed cameras (StageSpec.runs_without_failed_cameras): the cameras'
        inputs are dropped, its ProjectWide parameters leave them out and say why.
        """
        inputs = {
            label: source
            for label, source in self.inputs.items()
            if ":" not in label or label.rpartition(":")[2] not in reasons
        }
        deps = [d for d in self.deps if d not in incomplete]
        return dataclasses.replace(self, inputs=inputs, params=self.params.leaving_out(reasons), deps=deps)


@dataclass
class Given:
    """An artefact the user brings instead of running a stage."""

    stage: str
    camera: str | None
    path: Path

    @property
    def id(self) -> str:
        return task_id(self.stage, self.camera)


def task_id(stage: str, camera: str | None) -> str:
    return f"{stage}/{camera}" if camera else stage


@dataclass
class Graph:
    """Every task of a project in an order where inputs come before their users."""

    project: Project
    workspace: Workspace
    tasks: dict[str, Task]
    given: dict[str, Given]
    options: Options = field(default_factory=Options)

    @property
    def work(self) -> Path:
        return self.workspace.work

    def select(self, stage: str, camera: str | None = None) -> list[str]:
        """Task ids of one stage (for one camera: its task, or the project-wide one); InputError when none."""
        if stage not in STAGES:
            raise InputError(f"unknown stage {stage!r}; stages: {', '.join(STAGES)}")
        if camera is not None:
            self.project.camera(camera)
        ids = [
            t
            for t, task in self.tasks.items()
            if task.stage == stage and (camera is None or task.camera in (camera, None))
        ]
        if not ids:
            given = [g for g in self.given.values() if g.stage == stage and (camera is None or g.camera == camera)]
            if given:
                raise InputError(
                    f"{given[0].id}: the project brings this artefact ({given[0].path}); there is no stage to run"
                )
            raise InputError(
                f"{self.project.path}: nothing to run for stage {stage}" + (f" and camera {camera}" if camera else "")
            )
        return ids


class _Sources:
    """Sources (pipeline/spec.py) for one graph: which task makes each artefact, or which file the project brings."""

    def __init__(self, project: Project, options: Options, producers: dict[Artefact, str]):
        self.project, self.options, self.producers = project, options, producers

    def made(self, kind: str, camera: str | None = None) -> bool:
        return Artefact(kind, camera) in self.producers

    def artefact(self, kind: str, camera: str | None = None) -> Path | Artefact:
        if self.made(kind, camera):
            return Artefact(kind, camera)
        givable = _GIVEN[kind]
        path = givable.given(self.project, camera)
        if path is None:
            where = f"camera {camera!r}" if camera else "[target]"
            raise InputError(f"{self.project.path}: {where}: {givable.missing}")
        return path


def build_graph(project: Project, work: Path, options: Options = Options()) -> Graph:
    """The tasks of ``project`` with artefacts under ``work``; a task whose input cannot be made
    gets its ``problem``.
    """
    workspace = Workspace(work, project.root)
    names = project.names
    wanted = [
        (spec, cam)
        for spec in STAGE_SPECS.values()
        for cam in (names if spec.per_camera else [None])
        if spec.applies(project, cam)
    ]
    producers = {Artefact(kind, cam): task_id(spec.name, cam) for spec, cam in wanted for kind in spec.outputs}
    sources = _Sources(project, options, producers)
    tasks: dict[str, Task] = {}
    for spec, cam in wanted:
        problem, params = None, None
        try:
            inputs = spec.inputs(sources, cam)
            params = spec.params(project, cam, options)
        except InputError as exc:
            inputs, problem = {}, str(exc)
        deps = sorted({producers[source] for source in inputs.values() if isinstance(source, Artefact)})
        outputs = [Artefact(kind, cam) for kind in spec.outputs]
        task = Task(spec, cam, inputs, params, outputs, deps, problem)
        tasks[task.id] = task
    given = {}
    for kind, givable in _GIVEN.items():
        for cam in names if kind != "trajectory" else [None]:
            path = givable.given(project, cam)
            if path is not None and Artefact(kind, cam) not in producers:
                given[task_id(MAKER[kind], cam)] = Given(MAKER[kind], cam, path)
    return Graph(project, workspace, tasks, given, options)
