"""Machine-readable summaries: ``tlsync status --json`` and ``tlsync run --json`` (docs/formats.md).

Both documents list every task (a stage for a camera, or for the project)
with its state, the reasons and the artefacts its manifest records (paths
relative to the work folder), and every camera with whether it is
synchronized and, if not, why.
"""

from __future__ import annotations

import json
from pathlib import Path

from tlsync_pipeline.errors import describe_error, one_line
from tlsync_pipeline.pipeline.cache import read_manifest
from tlsync_pipeline.pipeline.engine import RunSummary, TaskState, manifest_path
from tlsync_pipeline.pipeline.graph import Graph

STATUS_FORMAT = "tlsync-status"
RUN_FORMAT = "tlsync-run"
VERSION = 1


def status_document(graph: Graph, rows: list[TaskState], running: dict | None, exit_code: int) -> dict:
    """The ``tlsync status --json`` document."""
    cameras = {name: {"state": "unknown", "reason": None} for name in _camera_names(graph)}
    sync = next((r for r in rows if r.id == "sync"), None)
    if sync is not None and sync.state == "fresh":
        for name in cameras:
            cameras[name] = {"state": "synchronized", "reason": None}
    for row in rows:
        if row.stage == "sync" and row.camera is not None:
            cameras[row.camera] = {"state": "failed", "reason": row.reasons[0] if row.reasons else None}
    tasks = [
        {"id": r.id, "stage": r.stage, "camera": r.camera, "state": r.state, "reasons": [] if r.state == "given" else r.reasons, "artefacts": r.reasons if r.state == "given" else r.artefacts}
        for r in rows
    ]
    return _document(STATUS_FORMAT, graph, exit_code, tasks, cameras, running=running)


def run_document(graph: Graph, summary: RunSummary, exit_code: int) -> dict:
    """The ``tlsync run --json`` document: what this run did with each task, and each camera's result."""
    tasks = []
    for tid, task in graph.tasks.items():
        reasons: list[str]
        if tid in summary.ran:
            state, reasons = "ran", []
        elif tid in summary.fresh:
            state, reasons = "fresh", []
        elif tid in summary.failed:
            state, reasons = "failed", [describe_error(summary.failed[tid])]
        elif tid in summary.skipped:
            state, reasons = "skipped", [summary.skipped[tid]]
        else:
            state, reasons = "not run", []
        manifest = read_manifest(manifest_path(graph, task)) if state in ("ran", "fresh") else None
        tasks.append(
            {
                "id": tid,
                "stage": task.stage,
                "camera": task.camera,
                "state": state,
                "reasons": reasons,
                "warnings": [one_line(w) for w in summary.results[tid].warnings] if tid in summary.results else [],
                "seconds": summary.seconds.get(tid),
                "artefacts": sorted(manifest.outputs) if manifest else [],
            }
        )
    cameras = {name: {"state": "unknown", "reason": None} for name in _camera_names(graph)}
    if "sync" in summary.ran + summary.fresh:
        data = json.loads(graph.workspace.path("timeline").read_text(encoding="utf-8"))
        for name in cameras:
            failed = data.get("failed", {}).get(name)
            cameras[name] = {"state": "failed", "reason": one_line(failed)} if failed else {"state": "synchronized", "reason": None}
    return _document(RUN_FORMAT, graph, exit_code, tasks, cameras)


def dumps(document: dict) -> str:
    return json.dumps(document, indent=1)


def _camera_names(graph: Graph) -> list[str]:
    return graph.project.names


def _document(fmt: str, graph: Graph, exit_code: int, tasks: list[dict], cameras: dict, **extra) -> dict:
    return {"format": fmt, "version": VERSION, "project": str(Path(graph.project.path)), "work": str(graph.work), "exit_code": int(exit_code), **extra, "tasks": tasks, "cameras": cameras}
