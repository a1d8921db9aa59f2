"""Machine-readable summaries: ``tlsync status --json`` and ``tlsync run --json`` (docs/formats.md).

Both documents list every task (a stage for a camera, or for the project)
with its state, the reasons and the artefacts its manifest records (paths
relative to the work folder), and every camera with its status as
timeline.json gives it (sync/model/status.py: ok, weak, ambiguous, failed, with
reasons and a remedy), or ``unknown`` while there is no current timeline.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from tlsync_pipeline.errors import describe_error, one_line
from tlsync_pipeline.pipeline.cache import read_manifest
from tlsync_pipeline.sync.timeline import read_timeline

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.engine import RunSummary, TaskState
    from tlsync_pipeline.pipeline.graph import Graph

STATUS_FORMAT = "tlsync-status"
RUN_FORMAT = "tlsync-run"
VERSION = 1


def status_document(graph: Graph, rows: list[TaskState], running: dict | None, exit_code: int) -> dict:
    """The ``tlsync status --json`` document."""
    sync = next((r for r in rows if r.id == "sync"), None)
    cameras = camera_statuses(graph, sync is not None and sync.state == "fresh")
    tasks = [
        {
            "id": r.id,
            "stage": r.stage,
            "camera": r.camera,
            "state": r.state,
            "reasons": [] if r.state == "given" else r.reasons,
            "artefacts": r.reasons if r.state == "given" else r.artefacts,
        }
        for r in rows
    ]
    return _document(STATUS_FORMAT, graph, exit_code, tasks, cameras, running=running)


def run_document(graph: Graph, summary: RunSummary, exit_code: int) -> dict:
    """The ``tlsync run --json`` document: what this run did with each task, and each camera's result."""
    from tlsync_pipeline.pipeline.engine import manifest_path

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
    return _document(RUN_FORMAT, graph, exit_code, tasks, camera_statuses(graph, "sync" in summary.ran + summary.fresh))


def dumps(document: dict) -> str:
    return json.dumps(document, indent=1)


UNKNOWN = {
    "status": "unknown",
    "synchronized": False,
    "reason": "no current timeline (run the sync stage)",
    "remedy": "tlsync run",
    "reasons": [],
}


def camera_statuses(graph: Graph, current: bool) -> dict[str, dict]:
    """Every camera's status from timeline.json when it is current, else ``unknown``; a camera whose recording
    breaks adds its ``segments`` and ``breaks`` (as timeline.json's camera entry)."""
    if not current:
        return {name: dict(UNKNOWN) for name in graph.project.names}
    timeline = read_timeline(graph.workspace.path("timeline"))
    found = timeline.statuses()
    out = {name: found[name].to_dict() if name in found else dict(UNKNOWN) for name in graph.project.names}
    for name, line in timeline.cameras.items():
        if name in out and line.clock.segments:
            out[name]["segments"] = [seg.to_dict() for seg in line.clock.segments]
            out[name]["breaks"] = [b.to_dict() for b in line.breaks or ()]
    return out


def _document(fmt: str, graph: Graph, exit_code: int, tasks: list[dict], cameras: dict, **extra) -> dict:
    return {
        "format": fmt,
        "version": VERSION,
        "project": str(Path(graph.project.path)),
        "work": str(graph.work),
        "exit_code": int(exit_code),
        **extra,
        "tasks": tasks,
        "cameras": cameras,
    }
