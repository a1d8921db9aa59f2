"""A long recording in small: the target in view in a fifth of each video, look-alikes all the time.

Two cameras recording at the same time (15 fps, 100 s, a keyframe every 4 s,
320x240, two look-alikes wandering each view) and a target that stays 30 s
in each view and rests out of view in between. The scan stage's coarse pass
over the keyframes puts windows around each stay; the track stage reads
only those; the timeline is the full pass's (``[track] scan = "full"``) to
within 0.05 frame, and says how each video was read.
"""

import functools
import shutil

import pytest

from data_fixtures.long_video import render_long_camera_video
from data_fixtures.raw_project import LONG_RECORDING, make_raw_project
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.sync.timeline import eps_t, read_timeline

pytestmark = pytest.mark.slow  # minutes of decoding and tracking: CI's slow tier


def _run(project_file, work):
    project = load_project(project_file)
    summary = run_graph(build_graph(project, work, Options(progress=False)))
    assert not summary.failed, summary.failed
    return summary, read_timeline(work / "timeline.json")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("long") / "raw"
    project_file, scene = make_raw_project(
        folder, LONG_RECORDING, render=functools.partial(render_long_camera_video, radius=5.0, look_alikes=2)
    )
    auto = _run(project_file, folder / "work_auto")
    full_file = folder / "project_full.toml"
    full_file.write_text(project_file.read_text() + '\n[track]\nscan = "full"\n')
    full = _run(full_file, folder / "work_full")
    return scene, auto, full, folder


def test_the_track_stage_reads_only_the_windows(runs):
    scene, (summary, timeline), _, folder = runs
    assert {f"scan/{name}" for name in scene.n_frames} <= set(summary.ran)
    for name, line in timeline.cameras.items():
        scan = line.scan
        assert scan.mode == "windows" and scan.reason == "", scan
        assert scan.keyframes_decoded == 1500 // 60
        track = scene.tracks[name]
        assert len(track) <= scan.frames_decoded <= 0.5 * scan.frames  # the stay (a fifth) and its margins


def test_the_same_timeline_as_reading_every_frame(runs):
    scene, (_, auto), (summary, full), _ = runs
    assert not any(task.startswith("scan/") for task in summary.ran)  # scan = "full": no coarse pass
    for line in full.cameras.values():
        assert line.scan.mode == "full" and "scan" in line.scan.reason and line.scan.frames_decoded == line.scan.frames
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        assert eps_t(auto.relation(a, b), full.relation(a, b), scene.n_frames[a]) <= 0.05, key
        assert eps_t(auto.relation(a, b), truth, scene.n_frames[a]) <= 0.5, key


def test_a_changed_gcp_keeps_the_windows(runs, tmp_path):
    """A calibration change re-runs the coarse pass; the track stage, whose windows did not change,
    does not run again.
    """
    scene, _, _, folder = runs
    copy = tmp_path / "raw"
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("work_full"))
    gcp = copy / "cam1" / "gcp.csv"
    lines = gcp.read_text().splitlines()
    name, u, v, *rest = lines[1].split(",")
    lines[1] = ",".join([name, f"{float(u) + 0.3:.2f}", v, *rest])
    gcp.write_text("\n".join(lines) + "\n")
    summary, _ = _run(copy / "project.toml", copy / "work_auto")
    assert "scan/cam1" in summary.ran and "track/cam1" not in summary.ran
