"""The table of artefact kinds: every name resolves, and each kind's reader reads back what its writer wrote."""

from __future__ import annotations

import ast
import importlib
import json
from pathlib import Path

import numpy as np
import pytest

from calibration.camera import Camera, read_camera
from data_fixtures.scene import make_scene
from tlsync_pipeline.artefacts.calibration import CalibrationReport, IntrinsicsReport
from tlsync_pipeline.artefacts.clock import ClockPrior, RecordedClock
from tlsync_pipeline.artefacts.identification import IdentificationRecord, IdentificationSummary, TrackletShare
from tlsync_pipeline.artefacts.kinds import KINDS, artefact_path
from tlsync_pipeline.artefacts.scan import CoarseLine, ScanPlan
from tlsync_pipeline.artefacts.video_info import VideoInfo
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.report import Gap, IngestReport
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.vote.votes import CameraVotes, Votes
from trackers.background import Background
from trackers.breaks import Break
from trackers.detections import make_detections


def resolve(name: str):
    module, _, attr = name.partition(":")
    return getattr(importlib.import_module(module), attr)


def intrinsics_only(camera: Camera, path: Path) -> Camera:
    """An intrinsics-only camera (no R, t: a pose to estimate), as the intrinsics stage writes one."""
    path.write_text(
        json.dumps(
            {"K": camera.K.tolist(), "dist": camera.dist.tolist(), "image_size": list(camera.image_size), "rms": 0.3}
        ),
        encoding="utf-8",
    )
    found = read_camera(path)
    assert not found.posed
    return found


def examples(tmp_path: Path) -> dict:
    """One value of every kind that has a reader and a writer."""
    scene = make_scene(0)
    camera = scene.cameras["cam0"]
    inputs = {n: CameraInput(scene.cameras[n], scene.tracks[n], scene.cameras[n].fps) for n in scene.cameras}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams())
    breaks = (Break("gap", 120, 3), Break("frozen", 300, 2))
    summary = IdentificationSummary(
        40, 35, (TrackletShare(3, 30, 0.86, 0.9), TrackletShare(7, 5, 0.14, 0.5)), 33, 4, 2, 0.4, (10.0, -3.5)
    )
    report = IngestReport(
        "log.gpx",
        "gpx",
        "ENU",
        100,
        98,
        98,
        10.0,
        1.7e9,
        "2023-11-14T22:13:20Z",
        9.8,
        [10.0, 5.0, 1.0],
        0.4,
        [Gap("line 40", 3.9, 4.3, 0.4, True)],
        0,
        {"exact duplicate": {"count": 2, "first": [3, 9]}},
        "line",
        0,
        {"lat": 46.5, "lon": 6.6, "alt": 400.0, "rule": "first fix"},
        {"max_speed_mps": 60.0},
        warnings=["a warning"],
        log_model={"name": "gnss", "why": "a GPX log"},
    )
    return {
        "intrinsics": intrinsics_only(camera, tmp_path / "intrinsics.json"),
        "intrinsics_report": IntrinsicsReport(
            {"rms": 0.3, "per_view": [{"image": "a.png", "error_px": 0.2}], "rejected": []}
        ),
        "camera": camera,
        "calibration_report": CalibrationReport({"camera": "cam0", "intrinsics": {"rms": 0.3}, "pose": None}),
        "track": scene.tracks["cam0"],
        "detections": make_detections(
            [(0, 0.0, 1, 10.5, 20.25, 4, 8, 0.5), (0, 0.0, 2, 30, 40, 4, 8, 0.5), (1, 0.1, 1, 11, 21, 4, 8, 0.9)]
        ),
        "scan": ScanPlan(False, "", ((120, 400), (900, 1000)), 3000, CoarseLine(2.0, 130.5, 12, 2, 40, 0.7), 40),
        "background": Background(
            np.arange(12, dtype=np.float32).reshape(3, 4) + 0.5, np.full((3, 4), 1.25, np.float32)
        ),
        "identification": IdentificationRecord(summary, breaks=breaks),
        "video_info": VideoInfo("cam0.mp4", 3000, 3002, True, "windows", "", 40, 380, breaks),
        "clock": RecordedClock(ClockPrior(1.7e9 + 0.25, 1.0, "the video's creation time")),
        "votes": CameraVotes(Votes(np.array([1.0, 2.0]), np.array([10.0, 12.5]), np.array([0.5, 3.0]))),
        "trajectory": scene.trajectory,
        "ingest_report": report,
        "timeline": timeline,
    }


EXTRA = {  # the other states of a kind: a camera without a pose, a target not identified, no clock, no votes
    "identification": IdentificationRecord(None, "camera cam0: no mover follows the projected path"),
    "clock": RecordedClock(None, "the video's metadata says nothing of when it was recorded"),
    "votes": CameraVotes(Votes(np.zeros(0), np.zeros(0), np.zeros(0)), "camera cam0: no vote"),
    "scan": ScanPlan(True, "no packet index", ((0, 500),), 500),
    "video_info": VideoInfo("cam0.mp4", 500, 500, False),
}


def test_every_name_in_the_table_resolves():
    for name, kind in KINDS.items():
        assert isinstance(resolve(kind.type), type), name
        for function in (kind.reader, kind.writer):
            assert function is None or callable(resolve(function)), (name, function)
        assert kind.reader is None or kind.writer is not None, f"{name}: a reader without a writer"


def test_each_reader_reads_back_what_its_writer_wrote(tmp_path):
    values = examples(tmp_path)
    readable = {name for name, kind in KINDS.items() if kind.reader is not None}
    assert readable == set(values), "an example of every kind with a reader"
    cases = [(name, value) for name, value in values.items()] + list(EXTRA.items())
    for i, (name, value) in enumerate(cases):
        kind = KINDS[name]
        first, second = tmp_path / f"{i}_a_{Path(kind.path).name}", tmp_path / f"{i}_b_{Path(kind.path).name}"
        resolve(kind.writer)(value, first)
        read = resolve(kind.reader)(first)
        assert isinstance(read, resolve(kind.type)), name
        resolve(kind.writer)(read, second)
        if isinstance(value, Camera):  # reading makes R orthonormal again: the same camera to the last bits
            again = read_camera(second)
            assert all(
                np.allclose(getattr(read, k), getattr(again, k), rtol=0, atol=1e-12) for k in ("K", "dist", "R", "t")
            ), name
            assert (read.image_size, read.fps, read.to_estimate) == (again.image_size, again.fps, again.to_estimate), (
                name
            )
        else:
            assert first.read_bytes() == second.read_bytes(), name
        if isinstance(value, Background):
            assert np.array_equal(read.median, value.median) and np.array_equal(read.deviation, value.deviation)
        elif not isinstance(value, (CameraVotes,)) and name not in (
            "camera",
            "intrinsics",
            "track",
            "trajectory",
            "timeline",
            "detections",
        ):
            assert read == value, name  # the frozen dataclasses without arrays compare whole


def test_a_malformed_json_artefact_names_its_file(tmp_path):
    for name in ("scan", "identification", "video_info", "clock", "ingest_report", "intrinsics_report"):
        bad = tmp_path / f"{name}.json"
        bad.write_text('{"format": "x",\n', encoding="utf-8")
        with pytest.raises(InputError, match=f"{name}.json:2"):
            resolve(KINDS[name].reader)(bad)
    for name in ("scan", "identification", "video_info", "ingest_report"):
        wrong = tmp_path / f"wrong_{name}.json"
        wrong.write_text('{"format": "x"}\n', encoding="utf-8")
        with pytest.raises(InputError, match=f"wrong_{name}.json: not "):
            resolve(KINDS[name].reader)(wrong)


def test_paths_and_folders():
    assert artefact_path("track", "cam0") == "cameras/cam0/track.csv"
    assert artefact_path("timeline") == "timeline.json"
    assert [name for name, kind in KINDS.items() if kind.folder] == ["pictures"]


def test_the_table_imports_no_implementation():
    """kinds.py is a leaf: the engine and every stage import it without widening a stage's code (its cache key)."""
    source = Path(importlib.import_module("tlsync_pipeline.artefacts.kinds").__file__).read_text(encoding="utf-8")
    imported = [node for node in ast.walk(ast.parse(source)) if isinstance(node, (ast.Import, ast.ImportFrom))]
    assert all(isinstance(n, ast.ImportFrom) and n.module in ("__future__", "dataclasses") for n in imported)


def test_stage_modules_read_and_write_no_json_themselves():
    """Stages read and write their artefacts through the readers and writers the table names, not by hand."""
    stages = Path(importlib.import_module("tlsync_pipeline.pipeline.stages").__file__).parent
    by_hand = []
    for path in sorted(stages.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import) and any(a.name == "json" for a in node.names):
                by_hand.append(path.name)
            elif isinstance(node, ast.ImportFrom) and node.module == "json":
                by_hand.append(path.name)
    assert not by_hand, by_hand
