"""The track stage in a project and on the command line: same track whichever way it is asked for."""

import numpy as np
import pytest
from click.testing import CliRunner

from data_fixtures.video import render_video
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.track import track_camera
from trackers.detections import read_detections
from trackers.track import read_track
from trackers.tracking import track_video


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    return render_video(tmp_path_factory.mktemp("stage") / "cam0.mp4", n_frames=120, seed=7)


def _project(tmp_path, video, tracker="", extra_camera=""):
    text = f'[[cameras]]\nname = "cam0"\nvideo = "{video.path}"\n{tracker}\n{extra_camera}'
    path = tmp_path / "project.toml"
    path.write_text(text)
    return path


def test_without_init_box_stage_and_command_write_the_same_movers(tmp_path, video):
    project = _project(tmp_path, video)
    result = _run("track", project, "--quiet")
    assert result.exit_code == 0, result.output
    staged = tmp_path / "work" / "cameras" / "cam0" / "detections.csv"
    out = tmp_path / "standalone.csv"
    result = _run("track-video", video.path, "--out", out, "--quiet")
    assert result.exit_code == 0, result.output
    assert staged.read_bytes() == out.read_bytes()
    movers = read_detections(staged)
    on_target = np.hypot(movers.x - video.truth[movers.frame, 0], movers.y - video.truth[movers.frame, 1]) < 2.0
    assert on_target.sum() >= 0.9 * video.in_view.sum()  # the target is among the movers in its frames
    assert not (tmp_path / "work" / "cameras" / "cam0" / "track.csv").exists()


def test_a_blob_init_box_still_detects_every_mover(tmp_path, video):
    # In a project the blob tracker's init box seeds the identity (identify stage): the track stage
    # writes every mover, as `track-video` without --init; with --init, track-video follows one target.
    x0, y0 = (round(v) - 8 for v in video.truth[70])
    project = _project(tmp_path, video, f"[cameras.tracker]\ninit = [{x0}, {y0}, 17, 17]\ninit_frame = 70\n")
    result = _run("track", project, "--quiet")
    assert result.exit_code == 0, result.output
    staged = tmp_path / "work" / "cameras" / "cam0" / "detections.csv"
    out = tmp_path / "standalone.csv"
    assert _run("track-video", video.path, "--out", out, "--quiet").exit_code == 0
    assert staged.read_bytes() == out.read_bytes()
    single = tmp_path / "single.csv"
    assert (
        _run(
            "track-video", video.path, "--out", single, "--quiet", "--init", f"{x0},{y0},17,17", "--init-frame", "70"
        ).exit_code
        == 0
    )
    assert len(read_track(single)) > 40


@pytest.mark.parametrize(
    "tracker_table, options",
    [
        (
            '[cameras.tracker]\nkind = "csrt"\ninit = [{x0}, {y0}, 17, 17]\ninit_frame = 70\n',
            ["--tracker", "csrt", "--init", "{x0},{y0},17,17", "--init-frame", "70"],
        ),
    ],
)
def test_same_track_from_project_stage_and_standalone_command(tmp_path, video, tracker_table, options):
    assert video.in_view[70]
    x0, y0 = (round(v) - 8 for v in video.truth[70])
    project = _project(tmp_path, video, tracker_table.format(x0=x0, y0=y0))
    result = _run("track", project, "--quiet")
    assert result.exit_code == 0, result.output
    staged = tmp_path / "work" / "cameras" / "cam0" / "track.csv"
    assert "cam0: wrote" in result.output
    out = tmp_path / "standalone.csv"
    result = _run("track-video", video.path, "--out", out, "--quiet", *[o.format(x0=x0, y0=y0) for o in options])
    assert result.exit_code == 0, result.output
    assert staged.read_bytes() == out.read_bytes()
    spec = load_project(project).camera("cam0")
    track = track_camera(spec.name, spec.video, spec.tracker, progress=False)
    direct = track_video(
        video.path, kind=spec.tracker.kind, init=spec.tracker.init, init_frame=spec.tracker.init_frame, progress=False
    )
    assert (track.frame == direct.frame).all() and (track.x == direct.x).all()
    assert len(read_track(staged)) > 40


def test_work_option_and_camera_selection(tmp_path, video):
    project = _project(tmp_path, video, extra_camera='[[cameras]]\nname = "cam1"\ntrack = "given.csv"\n')
    work = tmp_path / "elsewhere"
    result = _run("track", project, "--work", work, "--quiet")
    assert result.exit_code == 0, result.output
    assert (work / "cameras" / "cam0" / "detections.csv").exists()
    assert not (work / "cameras" / "cam1").exists()  # brings its own track
    result = _run("track", project, "--camera", "cam1", "--quiet")
    assert result.exit_code == 2 and "track/cam1: the project brings this artefact" in result.output


def test_failed_run_keeps_the_cached_track(tmp_path, video):
    project = _project(tmp_path, video, '[cameras.tracker]\nkind = "csrt"\ninit = [10, 10, 17, 17]\ninit_frame = 500\n')
    cached = tmp_path / "work" / "cameras" / "cam0" / "track.csv"
    cached.parent.mkdir(parents=True)
    cached.write_text("frame,x,y\n0,1,2\n")
    result = _run("track", project, "--quiet")
    assert result.exit_code == 2 and "init frame 500 is past the end of the video (120 frames)" in result.output
    assert cached.read_text() == "frame,x,y\n0,1,2\n"
    assert sorted(p.name for p in cached.parent.iterdir()) == [
        "track.csv",
        "track.failure.json",
    ]  # no half file; why it failed


@pytest.mark.parametrize(
    "table, message",
    [
        ('[cameras.tracker]\nkind = "blobb"\n', r"unknown tracker kind 'blobb' \(did you mean 'blob'\?\)"),
        ("[cameras.tracker]\ninit = [1, 2, 3]\n", r"expected a box \[x, y, w, h\]"),
        ("[cameras.tracker]\ninit_frame = -2\n", "expected a 0-based frame index"),
        ("[cameras.tracker]\nkindd = 3\n", r"unknown key 'kindd' \(did you mean 'kind'\?\)"),
        (
            '[cameras.tracker]\nkind = "csrt"\ninit = [400, 10, 20, 20]\n',
            r"init box \[400, 10, 20, 20\] is outside the image \(320x240\)",
        ),
        ("[cameras.tracker.parameters]\ngate = 3\n", r"unknown parameter 'gate' \(did you mean 'gate_px'\?\)"),
    ],
)
def test_bad_tracker_tables_exit_2(tmp_path, video, table, message):
    result = _run("track", _project(tmp_path, video, table), "--quiet")
    assert result.exit_code == 2
    assert message in result.output or __import__("re").search(message, result.output), result.output


@pytest.mark.parametrize(
    "args, message",
    [
        (["--tracker", "meanshift"], "'meanshift' is not one of 'blob', 'csrt'"),
        (["--init", "1,2,3"], "expected X,Y,W,H"),
        (["--init", "300,100,40,40"], "is outside the image"),
        (["--init-frame", "120"], "init frame 120 is past the end"),
    ],
)
def test_track_video_bad_options_exit_2(tmp_path, video, args, message):
    result = _run("track-video", video.path, "--out", tmp_path / "t.csv", "--quiet", *args)
    assert result.exit_code == 2 and message in result.output, result.output
    assert not (tmp_path / "t.csv").exists()


def test_track_video_unreadable_file_exit_2(tmp_path):
    bad = tmp_path / "clip.mp4"
    bad.write_text("hello")
    result = _run("track-video", bad, "--out", tmp_path / "t.csv", "--quiet")
    assert result.exit_code == 2 and "error: clip.mp4: not a readable video file" in result.output


def test_progress_shows_frames_and_rate_and_quiet_silences_it(tmp_path, video):
    out = tmp_path / "t.csv"
    shown = CliRunner().invoke(main, ["track-video", str(video.path), "--out", str(out)])
    quiet = CliRunner().invoke(main, ["track-video", str(video.path), "--out", str(out), "--quiet"])
    assert shown.exit_code == 0 and quiet.exit_code == 0
    text = shown.output + (shown.stderr if shown.stderr_bytes is not None else "")
    assert "120/120" in text and "frame/s" in text
    assert "frame/s" not in quiet.output
