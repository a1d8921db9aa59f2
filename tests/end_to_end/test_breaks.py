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
import json
import shutil

import numpy as np
import pytest

from data_fixtures.breaks import BreakEdit, edit_camera, pair_errors, video_times
from data_fixtures.raw_project import SMALL, make_raw_project
from tlsync_pipeline.cli.json_output import camera_statuses
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.sync.timeline import read_timeline

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
