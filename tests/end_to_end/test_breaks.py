"""Raw projects whose cam1 recording breaks: frozen 25 frames, 25 frames dropped without a trace, a 5-frame stutter.

The small raw demo (data_fixtures.raw_project.SMALL), cam1's video edited
inside the target's visit (data_fixtures/breaks.py: decoded frames
re-encoded with PyAV), through every stage: the break is found (the frozen
pictures while tracking, the drop in the movers' votes), cam1 is fitted as
segments with the break's shift in whole frames, every pair maps within a
fraction of a frame of the truth on the frames it maps, maps none it should
not, and every output carries the segments.
"""

import csv
import functools
import json
import shutil

import numpy as np
import pytest

from data_fixtures.breaks import BreakEdit, edit_camera, pair_errors, video_times
from data_fixtures.long_video import render_long_camera_video
from data_fixtures.raw_project import LONG_RECORDING, SMALL, make_raw_project
from tlsync_pipeline.cli.json_output import camera_statuses
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.sync.timeline import read_timeline
from trackers.video import presentation_times

pytestmark = pytest.mark.slow

LINES = {f"cam{k}": line for k, line in enumerate(SMALL.lines)}
COUNTS = {f"cam{k}": n for k, n in enumerate(SMALL.n_frames)}


@pytest.fixture(scope="module")
def raw(tmp_path_factory):
    """The small raw demo, without a work folder."""
    project_file, _ = make_raw_project(tmp_path_factory.mktemp("breaks") / "raw", SMALL)
    return project_file.parent


def _run(raw, tmp_path, edit):
    folder = tmp_path / "project"
    shutil.copytree(raw, folder)
    sources = {name: np.arange(n, dtype=np.float64) for name, n in COUNTS.items()}
    sources["cam1"] = edit_camera(folder, "cam1", edit, 25.0)
    graph = build_graph(load_project(folder / "project.toml"), folder / "work", Options(progress=False))
    summary = run_graph(graph)
    assert not summary.failed
    assert camera_statuses(graph, True)["cam1"]["segments"], "tlsync status --json carries the segments"
    return folder / "work", read_timeline(folder / "work" / "timeline.json"), sources


@pytest.mark.parametrize(
    ("edit", "kind", "shift"),
    [
        (BreakEdit("frozen", 100, 25), "frozen", 25.0),
        (BreakEdit("dropped", 100, 25), "drop", -25.0),
        (BreakEdit("frozen", 100, 5), "frozen", 5.0),
    ],
    ids=["frozen25", "dropped25", "stutter5"],
)
def test_a_break_in_view_is_fitted_as_segments(raw, tmp_path, edit, kind, shift):
    work, timeline, sources = _run(raw, tmp_path, edit)
    status = timeline.status("cam1")
    assert status.synchronized and "segments" in [r.code for r in status.reasons], status
    line = timeline.cameras["cam1"]
    assert [(b.kind, b.frame) for b in line.breaks] == [(kind, 100)]
    segments = line.clock.segments
    before, after = segments[0], segments[-1]
    assert after.source == "line" and before.source == "votes" and before.shift == shift
    for name in ("cam0", "cam2"):
        assert timeline.status(name).status == "ok"
        for a, b in (("cam1", name), (name, "cam1")):
            errors, unmapped, false = pair_errors(timeline, LINES, sources, a, b, video_times(work.parent, COUNTS))
            assert unmapped == 0 and false == 0, (a, b)
            assert len(errors) == 0 or errors.max() < 0.15, (a, b, errors.max())
    with open(work / "exports" / "frame_map.csv", newline="") as handle:
        rows = {int(r["frame"]): r for r in csv.DictReader(handle) if r["camera"] == "cam1"}
    frozen = range(100, 100 + edit.size) if kind == "frozen" else ()
    assert all(rows[f]["sample"] == "" for f in frozen) and rows[99]["sample"] and rows[100 + edit.size]["sample"]
    sync = json.loads((work / "exports" / "sync.json").read_text())
    assert [s["first_frame"] for s in sync["cameras"]["cam1"]["segments"]] == [0, 100 + len(frozen)]
    assert (work / "render" / "recordings.png").exists()


@pytest.mark.parametrize("at", [100, 140])
def test_a_drop_of_five_frames_is_fitted_or_refused_with_the_drop_named(raw, tmp_path, at):
    """5 frames dropped without a trace: the line runs between the two sides (the votes' step, not a parallel line).
    cam1 is either refused with the drop named, or fitted as segments with every pair within a fraction of a frame."""
    folder = tmp_path / "project"
    shutil.copytree(raw, folder)
    sources = {name: np.arange(n, dtype=np.float64) for name, n in COUNTS.items()}
    sources["cam1"] = edit_camera(folder, "cam1", BreakEdit("dropped", at, 5), 25.0)
    run_graph(build_graph(load_project(folder / "project.toml"), folder / "work", Options(progress=False)))
    timeline = read_timeline(folder / "work" / "timeline.json")
    status = timeline.status("cam1")
    if not status.synchronized:
        assert [r.code for r in status.reasons if r.severity == "ambiguous"] == ["clock_break"], status
        assert f"at frame {at}" in status.reason and "jump of" in status.reason, status.reason
        return
    assert [(b.kind, b.frame) for b in timeline.cameras["cam1"].breaks] == [("drop", at)]
    for name in ("cam0", "cam2"):
        for a, b in (("cam1", name), (name, "cam1")):
            errors, unmapped, false = pair_errors(timeline, LINES, sources, a, b, video_times(folder, COUNTS))
            assert false == 0 and (len(errors) == 0 or errors.max() < 0.15), (a, b)


def test_an_unedited_demo_has_no_break(raw, tmp_path):
    folder = tmp_path / "project"
    shutil.copytree(raw, folder)
    run_graph(build_graph(load_project(folder / "project.toml"), folder / "work", Options(progress=False)))
    timeline = read_timeline(folder / "work" / "timeline.json")
    for name in COUNTS:
        assert (
            timeline.status(name).status == "ok"
            and not timeline.cameras[name].breaks
            and not timeline.cameras[name].clock.segments
        )
        assert json.loads((folder / "work" / "cameras" / name / "video.json").read_text())["breaks"] == []


def test_a_restart_before_the_target_arrives_leaves_the_earlier_piece_unknown(raw, tmp_path):
    """Cut at frame 15 and restarted 3 minutes later, the container's times re-stamped (running on): the earlier
    recording showed a car parked that has left by the restart; the target arrives at frame 23. The cut is found
    in the pictures, the piece before it is not guessed."""
    work, timeline, sources = _run(raw, tmp_path, BreakEdit("restart", 15, 4500, parked=True))
    status = timeline.status("cam1")
    assert status.synchronized and "segments" in [r.code for r in status.reasons], status
    line = timeline.cameras["cam1"]
    assert [(b.kind, b.frame) for b in line.breaks] == [("cut", 15)]
    assert [(s.start, s.source, s.shift) for s in line.clock.segments] == [(0, "unknown", None), (15, "line", 0.0)]
    for name in ("cam0", "cam2"):
        for a, b in (("cam1", name), (name, "cam1")):
            errors, unmapped, false = pair_errors(timeline, LINES, sources, a, b, video_times(work.parent, COUNTS))
            assert false == 0 and unmapped == 0, (a, b)
            assert len(errors) == 0 or errors.max() < 0.15, (a, b, errors.max())


def test_a_freeze_inside_a_window_of_a_long_recording_is_found(tmp_path):
    """A long recording read in windows (the scan stage's, around the target's stay): cam1 frozen 25 frames in the
    middle of the target's stay. The track stage reads only the windows; the freeze inside one is found and cam1
    fitted as segments as when every frame is read."""
    spec = LONG_RECORDING
    folder = tmp_path / "raw"
    _, scene = make_raw_project(
        folder, spec, render=functools.partial(render_long_camera_video, radius=5.0, look_alikes=2)
    )
    stay = scene.tracks["cam1"].frame
    at = int(stay[len(stay) // 2])
    fps = 1.0 / float(np.median(np.diff(presentation_times(folder / "cam1" / "video.mp4"))))
    sources = {name: np.arange(n, dtype=np.float64) for name, n in scene.n_frames.items()}
    sources["cam1"] = edit_camera(folder, "cam1", BreakEdit("frozen", at, 25), fps)
    summary = run_graph(build_graph(load_project(folder / "project.toml"), folder / "work", Options(progress=False)))
    assert not summary.failed
    timeline = read_timeline(folder / "work" / "timeline.json")
    line = timeline.cameras["cam1"]
    assert line.scan.mode == "windows" and line.scan.frames_decoded < 0.5 * line.scan.frames
    assert ("frozen", at, 25.0) in [(b.kind, b.frame, b.size) for b in line.breaks]
    assert timeline.status("cam1").synchronized and [s.shift for s in line.clock.segments if s.source == "votes"] == [
        25.0
    ]
    lines = {name: (rel.alpha, rel.beta) for name, rel in scene.lines.items()}
    errors, unmapped, false = pair_errors(timeline, lines, sources, "cam0", "cam1", video_times(folder, scene.n_frames))
    assert false == 0 and unmapped == 0
    assert errors.max() < 0.15, errors.max()


@pytest.fixture(scope="module")
def long_raw(tmp_path_factory):
    """A long recording (1500 frames at 15 fps, two look-alikes wandering) whose cameras the scan stage reads in
    windows around the target's stay; its scene."""
    spec = LONG_RECORDING
    folder = tmp_path_factory.mktemp("long") / "raw"
    _, scene = make_raw_project(
        folder, spec, render=functools.partial(render_long_camera_video, radius=5.0, look_alikes=2)
    )
    return folder, scene


@pytest.mark.parametrize(
    ("edit", "kind", "segments"),
    [
        (BreakEdit("frozen", 400, 25), "frozen", [(0, "unknown"), (400, "frozen"), (425, "line")]),
        (BreakEdit("restart", 400, 4500, parked=True), "cut", [(0, "unknown"), (400, "line")]),
    ],
    ids=["frozen25", "restart_parked"],
)
def test_a_break_between_the_windows_of_a_long_recording_is_read(long_raw, tmp_path, edit, kind, segments):
    """cam1 frozen 25 frames, or cut and restarted 5 minutes later (re-stamped, a car parked before), at frame 400:
    long before the target's stay (frames 760-1230), outside the windows the scan stage reads for it. The scan
    stage's checks (a run of packets coded to nothing, a cut between two keyframes) have the track stage read
    around it: the break is found and the frames before it are left unknown, not mapped 25 frames (or 5 minutes)
    off."""
    raw, scene = long_raw
    folder = tmp_path / "raw"
    shutil.copytree(raw, folder)
    fps = 1.0 / float(np.median(np.diff(presentation_times(folder / "cam1" / "video.mp4"))))
    sources = {name: np.arange(n, dtype=np.float64) for name, n in scene.n_frames.items()}
    sources["cam1"] = edit_camera(folder, "cam1", edit, fps)
    summary = run_graph(build_graph(load_project(folder / "project.toml"), folder / "work", Options(progress=False)))
    assert not summary.failed
    timeline = read_timeline(folder / "work" / "timeline.json")
    line = timeline.cameras["cam1"]
    assert line.scan.mode == "windows" and line.scan.frames_decoded < 0.5 * line.scan.frames
    scan = json.loads((folder / "work" / "cameras" / "cam1" / "scan.json").read_text())
    assert all(stop <= edit.frame or start > 500 for start, stop in scan["windows"]), scan["windows"]
    assert any(start <= edit.frame < stop for start, stop in scan["checks"]), scan["checks"]
    assert [(b.kind, b.frame) for b in line.breaks] == [(kind, 400)]
    assert [(s.start, s.source) for s in line.clock.segments] == segments
    assert timeline.status("cam1").synchronized
    lines = {name: (rel.alpha, rel.beta) for name, rel in scene.lines.items()}
    times = video_times(folder, {**scene.n_frames, "cam1": len(sources["cam1"])})
    for a, b in (("cam0", "cam1"), ("cam1", "cam0")):
        errors, _, false = pair_errors(timeline, lines, sources, a, b, times)
        assert false == 0, (a, b)
        assert errors.max() < 0.15, (a, b, errors.max())
