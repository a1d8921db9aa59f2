"""The stage graph: cache keys, status, forced and single-stage runs, lock, failures, exports."""

import csv
import json
import os
import shutil

import pytest
from click.testing import CliRunner

from tlsync_pipeline.cli.exit_codes import ExitCode
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.pipeline import engine
from tlsync_pipeline.pipeline.cache import read_manifest
from tlsync_pipeline.pipeline.engine import run_graph, status
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.lock import WorkLock
from tlsync_pipeline.pipeline.project import load_project


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def _graph(project_dir, work=None):
    project = load_project(project_dir / "project.toml")
    return build_graph(project, work or project.default_work_dir)


def _states(project_dir):
    return {row.id: row for row in status(_graph(project_dir))}


def test_second_run_does_no_work_and_status_is_fresh(project_dir):
    first = run_graph(_graph(project_dir))
    assert sorted(first.ran) == ["export", "render", "sync", "vote/cam0", "vote/cam1"]
    second = run_graph(_graph(project_dir))
    assert second.ran == [] and len(second.fresh) == 5
    states = _states(project_dir)
    assert {r.state for r in states.values() if r.stage in ("vote", "sync", "export", "render")} == {"fresh"}
    assert states["track/cam0"].state == "given"


def test_changing_one_cameras_file_reruns_exactly_what_follows(project_dir):
    run_graph(_graph(project_dir))
    camera = project_dir / "cam1" / "camera.json"
    data = json.loads(camera.read_text())
    data["t"][0] += 0.01
    camera.write_text(json.dumps(data))
    states = _states(project_dir)
    assert states["vote/cam1"].state == "stale" and "camera.json" in states["vote/cam1"].reasons[0]
    assert states["vote/cam0"].state == "fresh"
    assert states["sync"].state == "stale"
    summary = run_graph(_graph(project_dir))
    assert sorted(summary.ran) == ["export", "render", "sync", "vote/cam1"]
    assert "vote/cam0" in summary.fresh


def test_parameter_change_is_named_in_status(project_dir):
    run_graph(_graph(project_dir))
    toml = project_dir / "project.toml"
    toml.write_text(toml.read_text().replace("eps_px = 10.0", "eps_px = 12.0"))
    states = _states(project_dir)
    assert any("eps_px: 10.0 -> 12.0" in r for r in states["vote/cam0"].reasons)


def test_force_and_single_stage_commands(project_dir):
    toml = project_dir / "project.toml"
    assert _cli("run", toml, "-j", "1", "-q").exit_code == 0
    result = _cli("run", toml, "-j", "1", "--force", "vote", "--camera", "cam0")
    assert "ran: vote/cam0" in result.output
    # identical votes: nothing downstream re-runs (the cache looks at contents)
    assert "sync" not in result.output.split("ran:")[1].splitlines()[0]
    result = _cli("vote", toml, "--camera", "cam1", "-j", "1")
    assert result.exit_code == 0 and "ran 1," in result.output and "ran: vote/cam1" in result.output
    result = _cli("sync", toml, "-j", "1")
    assert "ran: sync" in result.output
    assert _cli("sync", toml, "-j", "1", "-q").output == ""
    result = _cli("vote", toml, "--camera", "nope", "-j", "1")
    assert result.exit_code == 2 and "no camera named 'nope'" in result.output


def test_a_camera_without_inputs_blocks_only_what_needs_it(project_dir):
    toml = project_dir / "project.toml"
    toml.write_text(toml.read_text().replace('track = "cam1/track.csv"\n', ""))
    states = _states(project_dir)
    assert states["vote/cam1"].state == "blocked" and "give 'track'" in states["vote/cam1"].reasons[0]
    assert states["sync"].state == "blocked" and states["vote/cam0"].state == "missing"
    result = _cli("run", toml, "-j", "1")
    assert result.exit_code == 2 and "camera 'cam1': give 'track' (a track.csv) or 'video'" in result.output
    assert not (project_dir / "work").exists()
    result = _cli("vote", toml, "--camera", "cam0", "-j", "1")
    assert result.exit_code == 0 and "ran: vote/cam0" in result.output


def test_artefact_without_manifest_or_modified_is_not_fresh(project_dir):
    run_graph(_graph(project_dir))
    work = project_dir / "work"
    (work / "cameras" / "cam0" / "vote.manifest.json").unlink()  # as if killed before the manifest was written
    (work / "timeline.json").write_text("{}")  # edited by hand
    states = _states(project_dir)
    assert states["vote/cam0"].state == "missing"
    assert any("timeline.json was modified" in r for r in states["sync"].reasons)
    summary = run_graph(_graph(project_dir))
    assert {"vote/cam0", "sync"} <= set(summary.ran)
    assert json.loads((work / "timeline.json").read_text())["cameras"]


def test_manifest_records_inputs_params_and_outputs(project_dir):
    run_graph(_graph(project_dir))
    manifest = read_manifest(project_dir / "work" / "cameras" / "cam0" / "vote.manifest.json")
    assert manifest.stage == "vote" and manifest.camera == "cam0"
    # The votes depend on eps_px and on the method's trajectory preparation, not on other methods' keys.
    assert manifest.params["eps_px"] == 10.0
    assert manifest.params["preparation"] == {
        "method": "refined",
        "options": {"smooth_trajectory": True},
        "logged_point_above_m": 0.0,
    }
    assert "r" not in manifest.params and "delta" not in manifest.params
    assert manifest.inputs["track"]["path"] == "cam0/track.csv" and len(manifest.inputs["track"]["sha256"]) == 64
    assert list(manifest.outputs) == ["cameras/cam0/votes.npz"]
    assert "tlsync_pipeline.sync.vote.votes" in manifest.code and "tlsync_pipeline.pipeline.engine" not in manifest.code
    assert (
        manifest.seconds >= 0 and manifest.cpu_seconds is not None and manifest.cpu_seconds >= 0
    )  # the task's own run, where it ran
    sync = read_manifest(project_dir / "work" / "sync.manifest.json")
    assert sync.inputs["votes:cam1"]["path"] == "<work>/cameras/cam1/votes.npz"


def test_moving_the_project_and_its_work_folder_apart_keeps_everything_fresh(project_dir, tmp_path):
    run_graph(_graph(project_dir, tmp_path / "work_elsewhere"))
    shutil.copytree(project_dir, tmp_path / "moved" / "project")
    shutil.copytree(tmp_path / "work_elsewhere", tmp_path / "moved" / "deeper" / "work")
    moved = _graph(tmp_path / "moved" / "project", tmp_path / "moved" / "deeper" / "work")
    assert {row.state for row in status(moved) if row.state != "given"} == {"fresh"}
    assert run_graph(moved).ran == []


def test_a_second_run_on_a_locked_work_folder_is_refused(project_dir):
    with WorkLock(project_dir / "work"):
        result = _cli("run", project_dir / "project.toml", "-j", "1")
    assert result.exit_code == ExitCode.ENVIRONMENT
    assert "in use by another tlsync run" in result.output and f"pid {os.getpid()}" in result.output
    assert _cli("run", project_dir / "project.toml", "-j", "1").exit_code == 0


def test_failed_stage_keeps_last_good_artefacts_and_runs_the_rest(project_dir, monkeypatch):
    run_graph(_graph(project_dir))
    good = (project_dir / "work" / "cameras" / "cam1" / "votes.npz").read_bytes()
    # A broken track that passes no check until its stage reads it: make it the stage's problem.
    monkeypatch.setattr(engine, "validate_project", lambda *args: None)
    graph = _graph(project_dir)
    (project_dir / "cam1" / "track.csv").write_text("frame,x,y\n0,1\n")
    summary = run_graph(graph)
    assert "vote/cam1" in summary.failed and "track.csv:2" in str(summary.failed["vote/cam1"])
    assert {"sync", "export", "render"} <= set(summary.ran)  # for the other camera
    timeline = json.loads((project_dir / "work" / "timeline.json").read_text())
    assert list(timeline["cameras"]) == ["cam0"] and timeline["failed"]["cam1"].startswith("vote/cam1 failed: ")
    assert (project_dir / "work" / "cameras" / "cam1" / "votes.npz").read_bytes() == good
    row = _states(project_dir)["vote/cam1"]  # its manifest is the last good run's; its inputs make it fail
    assert row.state == "failed" and "track.csv:2" in row.reasons[0]


def test_exports(project_dir, paper_scene):
    assert _cli("run", project_dir / "project.toml", "-j", "1", "-q").exit_code == 0
    work = project_dir / "work"
    with open(work / "exports" / "frame_map.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    n = {name: int(paper_scene.tracks[name].frame.max()) + 1 for name in ("cam0", "cam1")}
    assert len(rows) == n["cam0"] + n["cam1"]
    truth = paper_scene.truth_pairs()["cam0->cam1"]
    row = next(r for r in rows if r["camera"] == "cam0" and r["frame"] == "200")
    assert float(row["frame_cam1"]) == pytest.approx(truth(200), abs=1.0)
    assert float(row["sample"]) == pytest.approx((200 - 4) / 2, abs=0.5)
    with open(work / "exports" / "offsets.csv", newline="") as handle:
        offsets = {r["camera"]: r for r in csv.DictReader(handle)}
    assert float(offsets["cam1"]["start_frames"]) == pytest.approx(-truth.beta / truth.alpha, abs=1.0)
    script = (work / "exports" / "ffmpeg.sh").read_text()
    assert "ffmpeg -y -ss" in script and "-itsoffset" in script
    report = (work / "report.md").read_text()
    assert "render/votes_cam0.png" in report and (work / "render" / "votes_cam0.png").stat().st_size > 1000


def test_process_executor_gives_the_same_timeline(project_dir, tmp_path):
    toml = project_dir / "project.toml"
    assert _cli("run", toml, "-j", "1", "-q", "--work", tmp_path / "serial").exit_code == 0
    assert _cli("run", toml, "-j", "2", "-q", "--work", tmp_path / "pool").exit_code == 0
    serial = json.loads((tmp_path / "serial" / "timeline.json").read_text())
    pool = json.loads((tmp_path / "pool" / "timeline.json").read_text())
    assert serial["cameras"] == pool["cameras"]


def test_a_run_forks_its_workers_server_after_the_input_checks_before_its_lock(project_dir, monkeypatch):
    """The server the workers fork from is forked once the checks have loaded their libraries (it inherits them), and
    before the run holds the work folder's lock (the server and its workers never hold it)."""
    from tlsync_pipeline.pipeline.executors import ProcessExecutor

    events = []
    checks = engine.validate_project
    monkeypatch.setattr(engine, "validate_project", lambda *args: (checks(*args), events.append("checked")))
    lock = project_dir / "work" / ".lock"
    forked = lambda self: events.append(("forked", lock.exists()))  # noqa: E731
    monkeypatch.setattr(ProcessExecutor, "fork_server", forked)
    executor = ProcessExecutor(2, preload=("json",))
    try:
        run_graph(_graph(project_dir), executor)
    finally:
        executor.close()
    assert events[:2] == ["checked", ("forked", False)]


def test_dask_executor_on_a_local_cluster(project_dir, tmp_path):
    distributed = pytest.importorskip("distributed")

    with distributed.LocalCluster(
        n_workers=2, processes=False, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        result = _cli(
            "run",
            project_dir / "project.toml",
            "--executor",
            "dask",
            "--scheduler",
            cluster.scheduler_address,
            "--work",
            tmp_path / "dask",
        )
    assert result.exit_code == 0, result.output
    assert sorted(result.output.split("ran: ")[1].splitlines()[0].split(", ")) == [
        "export",
        "render",
        "sync",
        "vote/cam0",
        "vote/cam1",
    ]
    assert json.loads((tmp_path / "dask" / "timeline.json").read_text())["cameras"]["cam1"]["alpha"] == pytest.approx(
        2.0, abs=0.01
    )
    assert _cli("run", project_dir / "project.toml", "--executor", "dask").exit_code == 2  # needs --scheduler


def test_ready_tasks_go_out_tracks_first_the_largest_video_first(tmp_path):
    """Scans and tracks before the other per-camera tasks (largest video first), project-wide tasks last."""
    from tlsync_pipeline.pipeline.engine import _priority

    (tmp_path / "boards").mkdir()
    (tmp_path / "boards" / "a.png").write_bytes(b"")
    (tmp_path / "target.gpx").write_text("")
    (tmp_path / "gcp.csv").write_text("name,u,v,lat,lon,alt\n")
    cameras = []
    for name, size in (("cam0", 1000), ("cam1", 5000), ("cam2", 3000)):
        (tmp_path / f"{name}.mp4").write_bytes(os.urandom(size))
        cameras.append(
            f'[[cameras]]\nname = "{name}"\nvideo = "{name}.mp4"\n'
            '[cameras.calibration]\nimages = "boards/*.png"\npattern = "7x5"\nsquare = 0.04\ngcp = "gcp.csv"\n'
        )
    (tmp_path / "project.toml").write_text(
        '[target]\nlog = "target.gpx"\norigin = [46.5, 6.6, 380.0]\n' + "".join(cameras)
    )
    graph = _graph(tmp_path)
    order = sorted(graph.tasks, key=lambda t: _priority(graph.tasks[t]))
    assert order[:6] == ["scan/cam1", "track/cam1", "scan/cam2", "track/cam2", "scan/cam0", "track/cam0"]
    from tlsync_pipeline.pipeline.graph import PER_CAMERA

    stages = [graph.tasks[t].stage for t in order]
    assert not {"scan", "track"} & set(stages[6:]) and {"intrinsics", "calibrate", "vote"} <= set(stages)
    per_camera = [stage in PER_CAMERA for stage in stages]
    assert per_camera == sorted(per_camera, reverse=True)  # the project-wide tasks last


def _same_size_edit(path):
    """Change one digit of a file, keeping its size and its modification time (as ``cp -p`` or ``rsync -t`` would)."""
    before = os.stat(path)
    text = path.read_text()
    k = next(i for i, c in enumerate(text) if c.isdigit() and c != "0" and i > 20)
    path.write_text(text[:k] + ("1" if text[k] != "1" else "2") + text[k + 1 :])
    os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))
    after = os.stat(path)
    assert (after.st_size, after.st_mtime_ns) == (before.st_size, before.st_mtime_ns)


def test_an_edit_that_keeps_size_and_mtime_is_seen(project_dir, monkeypatch):
    """The hash memo remembers a file by more than size and mtime: status says stale and run re-runs."""
    from tlsync_pipeline.pipeline import cache

    monkeypatch.setattr(cache, "_RACY_NS", 0)  # remember every file at once, as for files older than a few seconds
    run_graph(_graph(project_dir))
    _same_size_edit(project_dir / "cam1" / "camera.json")
    assert _states(project_dir)["vote/cam1"].state == "stale"
    assert "vote/cam1" in run_graph(_graph(project_dir)).ran


def test_the_content_sample_sees_an_edit_where_inode_and_ctime_stay(tmp_path, monkeypatch):
    """On a card (FAT, exFAT) the inode and ctime may not move with an edit: the sample of the content still does."""
    from tlsync_pipeline.pipeline import cache

    monkeypatch.setattr(cache, "_RACY_NS", 0)
    for size in (1000, 5 << 20):  # read whole, and sampled
        path = tmp_path / f"video{size}.bin"
        path.write_bytes(bytes(size))
        memo = cache.HashMemo(tmp_path / "memo.json")
        first = memo.sha256(path)
        with path.open("r+b") as handle:  # one byte of the first block
            handle.seek(10)
            handle.write(b"\x01")
        stat = os.stat(path)
        memo.entries[str(path.resolve())][:4] = [stat.st_size, stat.st_mtime_ns, stat.st_ino, stat.st_ctime_ns]
        assert memo.sha256(path) == cache.file_sha256(path) != first


def test_a_run_reads_a_files_content_sample_once_and_again_when_its_status_changes(tmp_path, monkeypatch):
    """One memo (one run) checks a big video for each task that reads it: its sample is read on the first check only,
    a new memo (the next run) reads it again, and so does a check after the file's status changed."""
    from tlsync_pipeline.pipeline import cache

    monkeypatch.setattr(cache, "_RACY_NS", 0)
    path = tmp_path / "video.bin"
    path.write_bytes(bytes(5 << 20))
    memo_file = tmp_path / "memo.json"
    earlier = cache.HashMemo(memo_file)  # an earlier run remembered it
    earlier.sha256(path)
    earlier.save()
    reads = []
    sample = cache.content_sample
    monkeypatch.setattr(cache, "content_sample", lambda p, size: reads.append(p) or sample(p, size))
    run = cache.HashMemo(memo_file)
    digests = [run.sha256(path) for _ in range(5)]
    assert len(reads) == 1 and len(set(digests)) == 1
    cache.HashMemo(memo_file).sha256(path)
    assert len(reads) == 2
    with path.open("r+b") as handle:
        handle.seek(10)
        handle.write(b"\x01")
    assert run.sha256(path) == cache.file_sha256(path) != digests[0]
