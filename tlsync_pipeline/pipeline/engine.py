"""Running the stage graph: what is fresh, what runs, in which order, where.

A task runs when one of its inputs, parameters or the code of its stage
changed since its manifest was written, when an artefact of it is missing or was
modified, or when it is forced. Its freshness is decided only once the tasks
that make its inputs are done, so a re-run stage whose artefacts come out
identical does not re-run what follows it. Per-camera tasks go to the
executor (parallel processes or a Dask cluster); project-wide ones run here,
and so do light per-camera ones (StageSpec.light) while the executor's local
workers are not started. This process's BLAS runs one thread, as the workers'
do: its tasks run beside them on busy cores. A failed task keeps its last
good artefacts; the tasks that need it are skipped and everything else still
runs. Every stage's result is a StageResult, handled the same way: the
engine names no stage.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tlsync_pipeline.artefacts.kinds import FOLDERS
from tlsync_pipeline.atomic import PART_SUFFIX
from tlsync_pipeline.errors import InputError, describe_error
from tlsync_pipeline.outputs.diagnostics import StageRun
from tlsync_pipeline.pipeline.cache import (
    HashMemo,
    Manifest,
    cache_key,
    failure_path,
    read_failure,
    read_manifest,
    staleness,
    write_failure,
    write_manifest,
)
from tlsync_pipeline.pipeline.codehash import code_digests
from tlsync_pipeline.pipeline.executors import (
    Called,
    ProcessExecutor,
    SerialExecutor,
    quiet_resource_tracker,
)
from tlsync_pipeline.pipeline.graph import STAGES, Graph, Task, task_id
from tlsync_pipeline.pipeline.lock import WorkLock
from tlsync_pipeline.pipeline.progress import Progress
from tlsync_pipeline.pipeline.spec import StageResult, params_json
from tlsync_pipeline.pipeline.stop import stop_requested
from tlsync_pipeline.pipeline.validate import validate_project
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.kernels.blas import one_blas_thread


@dataclass
class TaskState:
    """One row of ``tlsync status``: fresh, stale, missing, given, blocked or failed, why, and the artefacts on record.

    A camera a project-wide stage could not serve (the sync stage's cameras
    that are not synchronized) has a row of its own (id ``<stage>/<camera>``,
    state failed, the reason).
    """

    id: str
    stage: str
    camera: str | None
    state: str
    reasons: list[str] = field(default_factory=list)
    artefacts: list[str] = field(default_factory=list)  # relative to the work folder, as the manifest records them


@dataclass
class RunSummary:
    """What a run did: tasks run, found fresh, failed (with the error) and skipped for a failed input."""

    ran: list[str] = field(default_factory=list)
    fresh: list[str] = field(default_factory=list)
    failed: dict[str, BaseException] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    results: dict[str, StageResult] = field(default_factory=dict)
    warnings: dict[str, tuple[str, ...]] = field(
        default_factory=dict
    )  # of every task that ran or was fresh (its manifest's)


@dataclass
class _Key:
    """What a task's cache key is made of, as it is now: code, inputs (portable path and hash), parameters."""

    code: dict[str, str]
    inputs: dict[str, dict]
    params: dict
    key: str


def _current(graph: Graph, task: Task, memo: HashMemo, code: dict[str, dict]) -> _Key:
    """The task's key from its declaration; ``code`` caches module digests per stage module for one pass."""
    ws = graph.workspace
    module = task.spec.run.__module__
    if module not in code:
        code[module] = code_digests(module)
    inputs = {
        label: {"path": ws.portable(source), "sha256": memo.sha256(ws.resolve(source))}
        for label, source in sorted(task.inputs.items())
    }
    if task.spec.history:  # it shows the earlier stages' warnings: they are part of what it makes
        inputs[WARNINGS_INPUT] = {
            "path": "<the earlier stages' warnings>",
            "sha256": _warnings_digest(_history(graph, task)),
        }
    params = ws.portable(params_json(task.params))
    key = cache_key(task.stage, code[module], {k: v["sha256"] for k, v in inputs.items()}, params)
    return _Key(code[module], inputs, params, key)


WARNINGS_INPUT = "warnings"  # the label of a history stage's earlier warnings among its key's inputs


def manifest_path(graph: Graph, task: Task) -> Path:
    return graph.workspace.manifest(task.stage, task.camera)


def _reasons(graph: Graph, task: Task, now: _Key, memo: HashMemo) -> list[str]:
    return staleness(
        read_manifest(manifest_path(graph, task)), now.key, now.code, now.inputs, now.params, memo, graph.work
    )


def status(graph: Graph) -> list[TaskState]:
    """Every stage per camera: fresh, stale (with reasons), missing, given by the user, or blocked.

    A task whose input-making task is not fresh is stale ("waits for ...")
    even if its own manifest still matches: it will run after that one.
    """
    memo = HashMemo(graph.workspace.hash_memo)
    code: dict[str, dict] = {}
    rows: dict[str, TaskState] = {}
    for item in graph.given.values():
        rows[item.id] = TaskState(item.id, item.stage, item.camera, "given", [str(item.path)])
    for tid, task in graph.tasks.items():
        now = _current(graph, task, memo, code)
        manifest = read_manifest(manifest_path(graph, task))
        reasons = staleness(manifest, now.key, now.code, now.inputs, now.params, memo, graph.work)
        waiting = [d for d in task.deps if d in rows and rows[d].state in ("stale", "missing", "failed", "blocked")]
        failure = read_failure(failure_path(manifest_path(graph, task)))
        if task.problem:
            state, reasons = "blocked", [task.problem]
        elif failure is not None and failure["key"] == now.key and not waiting:
            state, reasons = "failed", [failure["reason"]]  # same inputs: it would fail again
        elif manifest is None:
            state = "missing"
        elif reasons or waiting:
            state = "stale"
        else:
            state = "fresh"
        if waiting:
            reasons.append("waits for " + ", ".join(f"{d} ({rows[d].state})" for d in waiting))
        rows[tid] = TaskState(
            tid, task.stage, task.camera, state, reasons, sorted(manifest.outputs) if manifest else []
        )
        if state == "fresh" and task.camera is None and manifest is not None:
            for camera, why in (manifest.summary.get("failed") or {}).items():
                rows[task_id(task.stage, camera)] = TaskState(
                    task_id(task.stage, camera), task.stage, camera, "failed", [why]
                )
    if graph.work.is_dir():  # status reads only: it never makes the work folder
        try:
            memo.save()
        except OSError:
            pass  # a read-only work folder: the hashes are only not remembered
    order = {s: i for i, s in enumerate(STAGES)}
    cameras = graph.project.names
    return sorted(rows.values(), key=lambda r: (order[r.stage], cameras.index(r.camera) if r.camera else -1))


def format_status(rows: list[TaskState]) -> str:
    """The ``tlsync status`` table: stage, camera, state, why."""
    lines = []
    width = max(len(r.stage) for r in rows)
    cam_width = max(len(r.camera or "-") for r in rows)
    for r in rows:
        why = "; ".join(r.reasons) if r.state != "fresh" else ""
        lines.append(
            f"{r.stage.ljust(width)}  {(r.camera or '-').ljust(cam_width)}  {r.state.ljust(7)}  {why}".rstrip()
        )
    return "\n".join(lines)


def task_files(graph: Graph, tid: str) -> StageFiles:
    """One task's view of its inputs and artefacts outside a run (the caller holds the work folder's lock)."""
    task = graph.tasks[tid]
    return graph.workspace.files(task.id, task.camera, task.inputs, task.outputs, progress=graph.options.progress)


def run_graph(
    graph: Graph,
    executor=None,
    force: set[str] | None = None,
    targets: list[str] | None = None,
    progress: Progress | None = None,
) -> RunSummary:
    """Run what is not fresh, holding the work folder's lock.

    force: task ids to run even when fresh. targets: the tasks wanted (default:
    all); the tasks they need run first when not fresh, nothing downstream of
    them runs. progress: told when each task starts, finishes or fails.
    """
    executor = executor or SerialExecutor()
    force = set(force or ())
    wanted = _closure(graph, targets) if targets is not None else list(graph.tasks)
    summary = RunSummary()
    validate_project(
        graph.project,
        {source for tid in wanted for source in graph.tasks[tid].inputs.values() if isinstance(source, Path)},
    )
    for tid in wanted:
        if graph.tasks[tid].problem:
            raise InputError(graph.tasks[tid].problem)
    if isinstance(executor, ProcessExecutor):
        executor.fork_server()  # here: its workers inherit the libraries the checks loaded (PyAV, OpenCV)
    with WorkLock(graph.work):
        if executor.cores > 1 or isinstance(
            executor, ProcessExecutor
        ):  # worker pools (the run's, the intrinsics stage's)
            quiet_resource_tracker()
        _remove_leftovers(graph.work)
        memo = HashMemo(graph.workspace.hash_memo)
        try:
            with one_blas_thread():
                _schedule(graph, executor, wanted, force, memo, summary, progress or Progress())
        except BaseException:
            executor.close(cancel=True)
            _remove_leftovers(graph.work)  # the stopped workers' temporary files (this run still holds the lock)
            _save_memo(memo, summary)
            raise
        _save_memo(memo, summary)
        executor.close()
    return summary


CACHE_TASK = "cache"  # the id under which a run reports that it could not remember its file hashes


def _save_memo(memo: HashMemo, summary: RunSummary) -> None:
    """Remember the file hashes; a failure (a full disk) is the run's to report beside its tasks',
    never in their place.
    """
    try:
        memo.save()
    except OSError as exc:
        summary.failed[CACHE_TASK] = exc


def _remove_leftovers(work: Path) -> None:
    """Delete temporary files a killed run left behind (safe: this run holds the lock)."""
    for leftover in work.rglob(f".*{PART_SUFFIX}"):
        leftover.unlink(missing_ok=True)


def _closure(graph: Graph, targets: list[str]) -> list[str]:
    needed = set()
    stack = list(targets)
    while stack:
        tid = stack.pop()
        if tid in needed or tid not in graph.tasks:
            continue
        needed.add(tid)
        stack.extend(graph.tasks[tid].deps)
    return [t for t in graph.tasks if t in needed]


def _schedule(
    graph: Graph, executor, wanted: list[str], force: set[str], memo: HashMemo, summary: RunSummary, progress: Progress
) -> None:
    _Scheduler(graph, executor, force, memo, summary, progress, list(wanted)).run()


@dataclass
class _Scheduler:
    """Hands out the wanted tasks as their inputs are made, collects their results, records what each did."""

    graph: Graph
    executor: Any
    force: set[str]
    memo: HashMemo
    summary: RunSummary
    progress: Progress
    pending: list[str]
    done: set[str] = field(default_factory=set)
    running: dict = field(default_factory=dict)  # future -> (task, its key, ran in a worker)
    code: dict[str, dict] = field(default_factory=dict)

    def run(self) -> None:
        while self.pending or self.running:
            self._hand_out()
            if not self.running:
                for tid in self.pending:  # every remaining task waits for something that will not come
                    self.summary.skipped[tid] = "its inputs were not made"
                return
            for future in executor_wait(self.executor, list(self.running)):
                self._collect(future)

    def _hand_out(self) -> None:
        """Start every task whose inputs are settled, in priority order; after a task run here, look again (its
        dependents may be ready).
        """
        progressed = True
        while progressed:
            progressed = False
            for tid in sorted(self.pending, key=lambda t: _priority(self.graph.tasks[t])):
                task = self._ready(tid)
                if task is None:
                    continue
                self.pending.remove(tid)
                progressed = True
                if task is _SKIPPED:
                    continue
                if self._start(task):
                    break

    def _ready(self, tid: str):
        """The task to run now (less the cameras whose tasks did not complete, for a stage that runs without them),
        _SKIPPED when it cannot run (recorded), or None while an input is still being made."""
        task = self.graph.tasks[tid]
        bad = [d for d in task.deps if d in self.summary.failed or d in self.summary.skipped]
        if bad and task.spec.runs_without_failed_cameras and all(self.graph.tasks[d].camera for d in bad):
            if not all(d in self.done or d in bad for d in task.deps):
                return None  # wait until every dependency is settled before deciding which cameras to leave out
            reasons: dict[str, str] = {}
            for d in bad:
                reasons.setdefault(self.graph.tasks[d].camera or "", _incomplete(d, self.summary))
            if len(reasons) < len(self.graph.project.cameras):
                task, bad = task.leaving_out(reasons, bad), []
        if bad:
            self.summary.skipped[tid] = f"needs {bad[0]}, which did not complete"
            return _SKIPPED
        if not all(d in self.done or d not in self.graph.tasks for d in task.deps):
            return None
        return task

    def _start(self, task: Task) -> bool:
        """Run the task unless it is fresh; whether it ran in this process (and is done)."""
        if stop_requested():  # a Ctrl-C an import swallowed (an ImportError caught by an optional import)
            raise KeyboardInterrupt
        now = _current(self.graph, task, self.memo, self.code)
        reasons = _reasons(self.graph, task, now, self.memo)
        if not reasons and task.id not in self.force:
            self.summary.fresh.append(task.id)
            manifest = read_manifest(manifest_path(self.graph, task))
            self.summary.warnings[task.id] = (
                tuple(manifest.summary.get("warnings") or ()) if manifest is not None else ()
            )
            self.done.add(task.id)
            return False
        executor = self.executor
        local = (
            task.camera is None
            or isinstance(executor, SerialExecutor)
            or (task.spec.light and not getattr(executor, "started", True))
        )
        self.progress.started(task.id, "forced" if not reasons else reasons[0], not local)
        where = SerialExecutor(executor.cores) if local else executor  # local tasks share the machine with the pool
        files = self.graph.workspace.files(
            task.id,
            task.camera,
            task.inputs,
            task.outputs,
            progress=self.graph.options.progress,
            cores=where.cores,
            history=_history(self.graph, task) if task.spec.history else [],
            workers=executor if local else None,
        )
        future = where.submit(run_task, {"run": task.spec.run, "files": files, "params": task.params})
        self.running[future] = (task, now, not local)
        if local:
            self._collect(future)
        return local

    def _collect(self, future) -> None:
        """Record a finished task: its manifest (its artefacts are good), or its failure (its last
        good artefacts stay).
        """
        task, now, parallel = self.running.pop(future)
        try:
            called: Called = future.result()
        except Exception as exc:  # noqa: BLE001 - recorded, reported by the caller
            if (
                stop_requested()
            ):  # a Ctrl-C that surfaced as the task's error (inside an import): the run stops, nothing failed
                raise KeyboardInterrupt from exc
            self.summary.failed[task.id] = exc
            write_failure(failure_path(manifest_path(self.graph, task)), now.key, describe_error(exc))
            self.progress.failed(task.id, exc, parallel)
            return
        result = dataclasses.replace(
            called.value, warnings=tuple(dict.fromkeys(called.value.warnings + called.warnings))
        )
        try:
            failure_path(manifest_path(self.graph, task)).unlink(missing_ok=True)
            _write_manifest(
                self.graph, task, now, result, called.seconds, called.cpu_s + result.worker_cpu_s, self.memo
            )
        except OSError as exc:  # a full disk: the artefacts are written but not recorded, so the task stays stale
            self.summary.failed[task.id] = exc
            self.progress.failed(task.id, exc, parallel)
            return
        self.summary.ran.append(task.id)
        self.summary.seconds[task.id] = called.seconds
        self.summary.results[task.id] = result
        self.summary.warnings[task.id] = result.warnings
        self.done.add(task.id)
        self.progress.finished(task.id, called.seconds, parallel)


_SKIPPED = object()  # _Scheduler._ready: the task cannot run


def _incomplete(task_id: str, summary: RunSummary) -> str:
    """Why a task did not complete, as one line: its failure, or why it was skipped."""
    if task_id in summary.failed:
        return f"{task_id} failed: {describe_error(summary.failed[task_id])}"
    return f"{task_id} did not run: {summary.skipped[task_id]}"


def executor_wait(executor, futures: list) -> list:
    """Futures that are done: the finished ones first (local ones are done at once)."""
    finished = [f for f in futures if f.done()]
    return finished or executor.wait_any(futures)


def run_task(run, files: StageFiles, params) -> StageResult:
    """Call a stage's function with its files and parameters (in whichever process the executor chose)."""
    with files.running():
        return run(files, params)


def _priority(task: Task) -> tuple:
    """Order in which ready tasks are handed out: per-camera tasks before project-wide ones (the pool works while
    those run here); heavy ones first (StageSpec.heavy), the largest inputs first, so that the longest task does not
    start last and leave one worker alone at the end; then the other per-camera tasks."""
    size = 0
    if task.spec.heavy:
        size = sum(Path(p).stat().st_size for p in task.inputs.values() if isinstance(p, Path) and Path(p).is_file())
    return (task.camera is None, not task.spec.heavy, -size)


def _history(graph: Graph, task: Task) -> list[StageRun]:
    """When and how long each task ``task`` needs (directly or not) last ran, and the warnings it recorded, in pipeline
    order, from their manifests (for the timeline's and the report's warnings, and the report's stage table)."""
    rows = []
    for tid in _closure(graph, list(task.deps)):
        manifest = read_manifest(manifest_path(graph, graph.tasks[tid]))
        if manifest is not None:
            summary = manifest.summary
            rows.append(
                StageRun(
                    manifest.stage,
                    manifest.camera,
                    manifest.created,
                    manifest.seconds,
                    tuple(summary.get("warnings") or ()),
                    summary.get("message"),
                )
            )
    return rows


def _warnings_digest(runs: list[StageRun]) -> str:
    """SHA-256 of the warnings the runs recorded (what a history stage shows of them)."""
    blob = json.dumps([[run.stage, run.camera, list(run.warnings)] for run in runs])
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


def _write_manifest(
    graph: Graph, task: Task, now: _Key, result: StageResult, seconds: float, cpu_seconds: float, memo: HashMemo
) -> None:
    ws = graph.workspace
    outputs = [ws.resolve(a) for a in task.outputs if a.kind not in FOLDERS] + [Path(p) for p in result.outputs]
    hashes = {}
    for path in outputs:
        digest = memo.sha256(path)
        if digest is not None:
            hashes[Path(path).relative_to(graph.work).as_posix()] = digest
    manifest = Manifest(
        task.stage,
        task.camera,
        now.code,
        now.key,
        now.inputs,
        now.params,
        hashes,
        round(seconds, 3),
        cpu_seconds=round(cpu_seconds, 3),
        summary=result.record(),
    )
    write_manifest(manifest, manifest_path(graph, task))
