"""From raw files (videos, checkerboard photos, GCPs, GPX) to the timeline, through every stage.

One small raw project (three cameras at 30, 25 and 15 fps, 320x240, shifts of
hundreds of frames) serves the whole story: a run killed mid-track resumes
and completes; the timeline is within one frame of the truth for every pair;
a second run does nothing. Then, each on its own copy of the finished
project (so each is also a moved project): the copy is all fresh; editing one
camera's GCPs re-runs exactly that camera's calibrate (the pose, not the
checkerboards' intrinsics) and vote, then sync, export and render; changing
a module's code makes exactly the stages that run it stale.
"""

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from data_fixtures.raw_project import SMALL, make_raw_project
from tlsync_pipeline.cli.exit_codes import ExitCode
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.pipeline import codehash
from tlsync_pipeline.pipeline.engine import run_graph, status
from tlsync_pipeline.pipeline.executors import ProcessExecutor
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.sync.timeline import eps_t, read_timeline

pytestmark = pytest.mark.slow  # minutes of decoding and tracking: CI's slow tier


def _graph(project_file):
    project = load_project(project_file)
    return build_graph(project, project.default_work_dir, Options(progress=False))


def _kill_mid_track(project_file, work):
    """Start `tlsync run` in a subprocess and SIGKILL its process group once tracking has started."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from tlsync_pipeline.cli.main import main; main()",
            "run",
            str(project_file),
            "-j",
            "2",
        ],
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
            time.sleep(0.2)  # mid-track: with 2 workers the third camera has not been tracked yet
            break
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    return "".join(lines)


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """The raw project after a killed run, its resumed run and a second (no-op) run; its project file."""
    project_file, scene = make_raw_project(tmp_path_factory.mktemp("raw") / "raw", SMALL)
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
    assert (
        again.ran == [] and len(again.fresh) == 25
    )  # intrinsics, calibrate, clock, scan, track, identify, vote per camera; ingest, sync, export, render
    return project_file


def _copy(project_file, tmp_path):
    """A copy of the finished project (with its work folder) in another folder; its project file."""
    shutil.copytree(project_file.parent, tmp_path / "copy")
    return tmp_path / "copy" / project_file.name


def _states(project_file):
    return {row.id: row for row in status(_graph(project_file))}


def test_a_copied_project_is_fresh_and_runs_nothing(finished, tmp_path):
    copy = _copy(finished, tmp_path)
    states = _states(copy)
    assert {row.state for row in states.values()} == {"fresh"}, {
        t: r.reasons for t, r in states.items() if r.state != "fresh"
    }
    assert run_graph(_graph(copy)).ran == []


def test_editing_a_gcp_reruns_the_pose_not_the_intrinsics(finished, tmp_path):
    project_file = _copy(finished, tmp_path)
    gcp = project_file.parent / "cam1" / "gcp.csv"
    lines = gcp.read_text().splitlines()
    name, u, v, *rest = lines[1].split(",")
    lines[1] = ",".join([name, f"{float(u) + 0.5:.2f}", v, *rest])
    gcp.write_text("\n".join(lines) + "\n")
    rows = _states(project_file)
    assert rows["calibrate/cam1"].state == "stale" and "gcp" in rows["calibrate/cam1"].reasons[0]
    assert rows["calibrate/cam0"].state == "fresh" and rows["track/cam1"].reasons == ["waits for scan/cam1 (stale)"]
    assert rows["intrinsics/cam1"].state == "fresh"
    edited = run_graph(_graph(project_file))
    # the coarse pass again (it votes with the camera), not the track stage: its windows did not change
    assert sorted(edited.ran) == [
        "calibrate/cam1",
        "export",
        "identify/cam1",
        "render",
        "scan/cam1",
        "sync",
        "vote/cam1",
    ]


def test_the_cameras_own_clocks_check_the_result_and_a_wrong_one_is_flagged_not_obeyed(finished, tmp_path):
    """The videos carry a phone's creation time (their true starts, whole seconds): every line agrees with it.
    Set one camera's clock a minute late in the project: only its clock stage and sync onwards re-run, the
    camera is flagged clock_disagrees (weak, with the numbers in timeline.json), and no line moves."""
    import datetime as dt

    from data_fixtures.raw_project import START_UTC
    from tlsync_pipeline.sync.clock_prior import CLOCK_FLAG

    right = read_timeline(finished.parent / "work" / "timeline.json")
    for name, line in right.cameras.items():
        check = line.clock_check
        assert check.source.startswith("QuickTime") and check.agrees and abs(check.offset_s) < 1.0, (name, check)
        assert CLOCK_FLAG not in (line.flags or ()) and right.status(name).status == "ok"
    project_file = _copy(finished, tmp_path)
    alpha, beta = SMALL.lines[1]
    late = dt.datetime.fromtimestamp(START_UTC - beta / alpha / SMALL.target_rate + 60.0, dt.timezone.utc).isoformat()
    head, cam0, cam1, cam2 = project_file.read_text().split("[[cameras]]")
    project_file.write_text(
        "[[cameras]]".join([head, cam0, cam1.rstrip("\n") + f'\n[cameras.clock]\nrecorded = "{late}"\n\n', cam2])
    )
    assert sorted(run_graph(_graph(project_file)).ran) == ["clock/cam1", "export", "render", "sync"]
    wrong = read_timeline(project_file.parent / "work" / "timeline.json")
    check = wrong.cameras["cam1"].clock_check
    assert (
        CLOCK_FLAG in wrong.cameras["cam1"].flags
        and check.source.startswith("the project")
        and abs(check.offset_s + 60.0) < 1.0
    )
    assert wrong.status("cam1").status == "weak" and wrong.status("cam0").status == "ok"
    for name in right.names:
        assert (wrong.cameras[name].alpha, wrong.cameras[name].beta) == (
            right.cameras[name].alpha,
            right.cameras[name].beta,
        )


def _changed(monkeypatch, module):
    """Make ``module``'s source (as the cache sees it) differ from the one the manifests recorded."""
    original = codehash.module_source
    monkeypatch.setattr(
        codehash, "module_source", lambda name: original(name) + (b"\n# changed\n" if name == module else b"")
    )


def test_changing_the_trackers_code_makes_only_track_and_what_follows_stale(finished, monkeypatch):
    _changed(monkeypatch, "trackers.blob")
    rows = _states(finished)
    stale = {tid for tid, row in rows.items() if row.state != "fresh"}
    cameras = ("cam0", "cam1", "cam2")
    # scan (keyframe movers) and track run the tracker's code; calibrate fits each camera's pose to its target near the
    # scan's
    # coarse offset, so it waits for both
    assert stale == {
        f"{stage}/{cam}" for stage in ("scan", "track", "calibrate", "identify", "vote") for cam in cameras
    } | {"sync", "export", "render"}
    assert rows["track/cam0"].reasons == ["code of trackers.blob changed", "waits for scan/cam0 (stale)"]
    assert rows["calibrate/cam0"].reasons[-1] == "waits for scan/cam0 (stale), track/cam0 (stale)"
    assert rows["identify/cam0"].reasons == ["waits for calibrate/cam0 (stale), track/cam0 (stale)"]
    assert rows["vote/cam0"].reasons == ["waits for calibrate/cam0 (stale), identify/cam0 (stale)"]


def test_changing_identification_makes_the_stages_that_identify_stale(finished, monkeypatch):
    _changed(monkeypatch, "tlsync_pipeline.sync.identify.refine")
    rows = _states(finished)
    stale = {tid for tid, row in rows.items() if row.state != "fresh"}
    # scan, calibrate (the pose from the target) and identify run the refinement; vote does not (it waits for identify),
    # nor does the track stage (it waits for its windows).
    assert stale == {
        f"{stage}/{cam}"
        for stage in ("scan", "track", "calibrate", "identify", "vote")
        for cam in ("cam0", "cam1", "cam2")
    } | {"sync", "export", "render"}
    assert rows["track/cam0"].reasons == ["waits for scan/cam0 (stale)"]
    assert rows["sync"].reasons[0] == "code of tlsync_pipeline.sync.identify.refine changed"
    assert rows["calibrate/cam0"].reasons == [
        "code of tlsync_pipeline.sync.identify.refine changed",
        "waits for scan/cam0 (stale), track/cam0 (stale)",
    ]
    assert rows["identify/cam0"].reasons == [
        "code of tlsync_pipeline.sync.identify.refine changed",
        "waits for calibrate/cam0 (stale), track/cam0 (stale)",
    ]
    assert rows["vote/cam0"].reasons == ["waits for calibrate/cam0 (stale), identify/cam0 (stale)"]


@pytest.mark.parametrize("module", ["tlsync_pipeline.sync.solve.log_bias", "tlsync_pipeline.sync.timeline"])
def test_changing_the_sync_fit_or_the_timeline_leaves_every_camera_stage_fresh(finished, monkeypatch, module):
    """The log's bias fit and the timeline's writer: scan, track, calibrate, identify and vote stay fresh; sync and
    what follows it are stale."""
    _changed(monkeypatch, module)
    rows = _states(finished)
    assert {tid for tid, row in rows.items() if row.state != "fresh"} == {"sync", "export", "render"}
    assert rows["sync"].reasons == [f"code of {module} changed"]


def _reverse_gpx(path: Path) -> None:
    """The GPX's track points in reverse order, each keeping the time of the point it replaces (a
    log reversed in time).
    """
    text = path.read_text(encoding="utf-8")
    point = re.compile(r'<trkpt lat="([^"]+)" lon="([^"]+)"><ele>([^<]+)</ele>(<time>[^<]+</time>)</trkpt>')
    found = point.findall(text)
    swapped = iter([(*where[:3], when[3]) for where, when in zip(found[::-1], found)])
    path.write_text(
        point.sub(lambda m: '<trkpt lat="{}" lon="{}"><ele>{}</ele>{}</trkpt>'.format(*next(swapped)), text),
        encoding="utf-8",
    )


def test_a_log_reversed_in_time_is_named_never_synchronized(finished, tmp_path):
    copy = _copy(finished, tmp_path)
    _reverse_gpx(copy.parent / "target.gpx")
    result = CliRunner().invoke(main, ["sync", str(copy), "-j", "1", "-q"], catch_exceptions=False)
    assert result.exit_code == ExitCode.NOT_SYNCHRONIZED, result.output
    timeline = read_timeline(copy.parent / "work" / "timeline.json")
    assert not timeline.cameras and set(timeline.failed) == {"cam0", "cam1", "cam2"}
    # the pose the target refines (calibrate) is the first to fail; where it identified the target, it says why
    assert any("the log looks reversed in time" in timeline.status(name).reason for name in timeline.failed), (
        timeline.failed
    )
