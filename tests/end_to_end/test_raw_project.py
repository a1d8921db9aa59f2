"""From raw files (videos, checkerboard photos, GCPs, GPX) to the timeline, through every stage.

One small raw project (three cameras at 30, 25 and 15 fps, 320x240, shifts of
hundreds of frames) serves the whole story: a run killed mid-track resumes
and completes; the timeline is within one frame of the truth for every pair;
a second run does nothing; editing one camera's GCPs re-runs exactly that
camera's calibrate (the pose, not the checkerboards' intrinsics) and vote,
then sync, export and render.
"""

import os
import signal
import subprocess
import sys
import time

from data_fixtures.raw_project import SMALL, make_raw_project
from tlsync_pipeline.pipeline.engine import run_graph, status
from tlsync_pipeline.pipeline.executors import ProcessExecutor
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.sync.timeline import eps_t, read_timeline


def _graph(project_file):
    project = load_project(project_file)
    return build_graph(project, project.default_work_dir, Options(progress=False))


def _kill_mid_track(project_file, work):
    """Start `tlsync run` in a subprocess and SIGKILL its process group once tracking has started."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen(
        [sys.executable, "-c", "from tlsync_pipeline.cli.main import main; main()", "run", str(project_file), "-j", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    lines = []
    for line in process.stderr:
        lines.append(line)
        if line.startswith("track/"):
            time.sleep(1.0)
            break
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    return "".join(lines)


def test_raw_project_end_to_end(tmp_path):
    project_file, scene = make_raw_project(tmp_path / "raw", SMALL)
    work = project_file.parent / "work"
    log = _kill_mid_track(project_file, work)
    assert "track/" in log, log
    rows = {row.id: row for row in status(_graph(project_file))}
    assert rows["sync"].state == "missing"
    assert any(row.state == "missing" for tid, row in rows.items() if tid.startswith("track/"))

    summary = run_graph(_graph(project_file), ProcessExecutor(2))
    assert not summary.failed and not summary.skipped
    assert not list(work.rglob("*.part")), "a killed run's temporary files must not survive the next run"
    assert "sync" in summary.ran and any(t.startswith("track/") for t in summary.ran)

    timeline = read_timeline(work / "timeline.json")
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        assert eps_t(timeline.relation(a, b), truth, scene.n_frames[a]) <= 1.0, key

    again = run_graph(_graph(project_file))
    assert again.ran == [] and len(again.fresh) == 16

    gcp = project_file.parent / "cam1" / "gcp.csv"
    lines = gcp.read_text().splitlines()
    name, u, v, *rest = lines[1].split(",")
    lines[1] = ",".join([name, f"{float(u) + 0.5:.2f}", v, *rest])
    gcp.write_text("\n".join(lines) + "\n")
    rows = {row.id: row for row in status(_graph(project_file))}
    assert rows["calibrate/cam1"].state == "stale" and "gcp" in rows["calibrate/cam1"].reasons[0]
    assert rows["calibrate/cam0"].state == "fresh" and rows["track/cam1"].state == "fresh"
    assert rows["intrinsics/cam1"].state == "fresh"
    edited = run_graph(_graph(project_file))
    assert sorted(edited.ran) == ["calibrate/cam1", "export", "render", "sync", "vote/cam1"]
