"""The trap suite: a working project with one ordinary mistake in it is synchronized right, or the run exits
non-zero with the cause named on the camera or the file; never a confident wrong answer.

Traps edit a copy of the quick demo's scene (tracks-only: seconds per trap;
data_fixtures/traps.py); a few use the real flight (../shared/real/drone2,
skipped when absent) and the small raw project (videos, a GPX log).
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from data_fixtures import make_scene, write_scene
from data_fixtures.traps import TRAPS, edit_camera, edit_key, edit_trajectory, read_project, write_project
from data_fixtures.video import blank_video
from tests.real_data import REAL_DATA
from tlsync_pipeline.cli.exit_codes import ExitCode
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.sync.timeline import eps_t, read_timeline, read_truth

QUICK_LINES = ((2.0, 4.0), (2.0, 45.0), (1.0, -30.5))  # tlsync demo --quick
REAL = REAL_DATA / "drone2"
RIGHT_FRAMES = 1.0  # a synchronized pair within this eps_t (frames) of the truth is right


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def quick(tmp_path_factory) -> Path:
    """The quick demo's project (three cameras at 30, 30 and 15 fps, tracks and calibrations given)."""
    root = tmp_path_factory.mktemp("quick")
    write_scene(make_scene(0, lines=QUICK_LINES, n_frames=(512, 512, 300), tracking_noise_px=1.0), root)
    return root


@pytest.fixture
def project(quick, tmp_path) -> Path:
    root = tmp_path / "project"
    shutil.copytree(quick, root)
    return root


def _wrong_pairs(root: Path, timeline) -> dict[str, float]:
    """The synchronized pairs further than RIGHT_FRAMES from the truth, with their eps_t."""
    truth, n_frames = read_truth(root / "truth.json")
    wrong = {}
    for key, relation in truth.items():
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            error = eps_t(timeline.relation(a, b), relation, n_frames.get(a) or 1)
            if not error <= RIGHT_FRAMES:
                wrong[key] = error
    return wrong


def _outcome(root: Path, *command: str):
    """(the run's result, its timeline or None when this run did not write one)."""
    timeline_file = root / "work" / "timeline.json"
    timeline_file.unlink(missing_ok=True)
    result = _cli(*(command or ("sync",)), root / "project.toml", "-j", "1", "-q")
    return result, read_timeline(timeline_file) if timeline_file.exists() else None


def _reasons(timeline) -> str:
    return "\n".join(
        f"{s.camera}: {s.status}: {'; '.join(f'{r.code} {r.text} (fix: {r.remedy})' for r in s.reasons)}"
        for s in timeline.statuses().values()
    )


# Per trap: the exit codes it may end with (0 only when every pair is right) and what must be named then.
EXPECTED = {
    "t_sample_numbers": (
        {2},
        r"trajectory.csv \(\[target\] trajectory\): column t: not seconds: .*sample numbers at 15 Hz\?\); set "
        r"\[target\] time_unit = 0.0666667$",
    ),
    "t_milliseconds": ({2}, r"\[target\] trajectory.*column t: .*milliseconds\?\); set \[target\] time_unit = \"ms\"$"),
    "t_twice": ({2}, r"column t: not seconds: .*time_unit = 0\.5$"),
    "reversed_in_time": ({1}, r"reversed"),
    "feet": ({2}, r"column x, y, z: not metres: .*\(ft\?\); set \[target\] length_unit = \"ft\"$"),
    "shifted_5m": ({0, 1}, r"off_path|not_synchronized"),
    "mirrored_x": ({1}, r"failed"),
    "rotated_90": ({1}, r"failed"),
    "z_flipped": ({0, 1}, r"off_path|not_synchronized"),
    "ned_not_enu": ({1}, r"failed"),
    "heights_47m_high": (
        {2},
        r"column z: heights 4[67](\.\d)? m too high: .*set \[target\] altitude_reference or altitude_offset_m = "
        r"-4[67](\.\d)?$",
    ),
    "antenna_1_5m_above": (
        {1},
        r"failed: log_height heights 1\.5 m too high: .*\(fix: the logged point rides 1\.5 m above the tracked one "
        r".*logged_point_above_m = 1\.5 ",
    ),
    "z_zero": (
        {1},
        r"failed: log_(flat|height) .*0 (m )?at every sample.*a log without heights\?.*\(fix: .*give a log with "
        r"heights",
    ),
    "random_walk": ({1}, r"failed"),
    "another_flight": ({1}, r"failed"),
    "log_ends_early": ({1}, r"failed"),
    "log_misses_a_camera": ({1}, r"cam1: failed"),
    "poses_swapped": ({1}, r"cam0: failed(.|\n)*cam1: failed|cam1: failed(.|\n)*cam0: failed"),
    "poses_rotated": ({1}, r"failed"),
    "camera_json_copied": ({2}, r"'cam1' camera \(cam1/camera.json\) is the same file as the camera of camera 'cam0'"),
    "track_copied": ({2}, r"'cam2' track \(cam2/track.csv\) is the same file as the track of camera 'cam1'"),
    "track_of_another_camera": ({1}, r"cam1: failed"),
    "track_of_the_shadow": (
        {1},
        r"cam1: failed: track_offset the track lies \d+ px .* off the projected path at every frame.*\(fix: the "
        r"tracker follows something beside the target \(its shadow\?\)",
    ),
    "track_of_another_object": ({1}, r"cam1: failed: track_elsewhere .*the tracker follows another object"),
    "fps_twice": ({1}, r"cam1: failed: .*clock .*runs at about (29|30)(\.\d+)? fps, not 60"),
    "fps_half": ({1}, r"cam1: failed: .*clock .*runs at about (29|30)(\.\d+)? fps, not 15"),
    "track_half_resolution": ({1}, r"cam1: failed"),
    "track_double_resolution": ({2}, r"'cam1' track: .*outside the camera's 640 x 480 image .*another resolution"),
    "pose_moved_5m": ({0, 1}, r"cam1: failed"),
    "pose_moved_50m": ({1}, r"cam1: failed"),
    "image_size_huge": ({2}, r"'cam1' camera: .*image_size"),
    "track_is_dev_zero": ({2}, r"'cam1' track: /dev/zero: not a regular file"),
    "track_is_proc_environ": ({2}, r"'cam1' track: /proc/\S+/environ: not a regular file"),
    "track_saved_by_excel": ({0}, r""),
    "track_normalised": (
        {2},
        r"'cam1' track: .*track.csv: every x, y lies within 0..1: normalised coordinates\? give pixels of the 640 x "
        r"480 image",
    ),
    "track_frame_in_seconds": (
        {2},
        r"'cam1' track: .*track.csv:\d+: column 'frame' holds times, not frame indices .*'time_s'$",
    ),
    "lon_lat_in_x_y": (
        {2},
        r"\[target\] trajectory: .*columns x, y look like longitude and latitude in degrees .*\[target\] log",
    ),
    "track_is_passwd": (
        {2},
        r"'cam1' track: .*track.csv:1: not a CSV header: one field of 31 characters, no ',' or ';' between column "
        r"names; expected a header with at least frame,x,y$",
    ),
    "track_frame_1e12": (
        {2},
        r"'cam1' track: .*track.csv:\d+: column 'frame': expected a 0-based integer frame index \(at most",
    ),
    "video_is_dev_urandom": ({2}, r"'cam1' video: /dev/urandom: not a regular file"),
    "video_missing": ({2}, r"'cam1' video: .*missing/video.mp4: file not found"),
}


def test_every_trap_has_an_expectation():
    assert set(EXPECTED) == set(TRAPS)


@pytest.mark.filterwarnings("error::RuntimeWarning")  # numpy's warnings never reach the user's terminal
@pytest.mark.parametrize("trap", sorted(TRAPS))
def test_a_trap_is_synchronized_right_or_named(project, trap):
    TRAPS[trap](project)
    result, timeline = _outcome(project)
    codes, cause = EXPECTED[trap]
    named = result.output + ("" if timeline is None else _reasons(timeline))
    assert result.exit_code in codes, named
    assert "Traceback" not in result.output
    if result.exit_code == ExitCode.BAD_INPUT:
        assert re.search(cause, result.output, re.M), result.output
        assert len(result.output.strip().splitlines()) == 1, result.output  # one line
        return
    assert timeline is not None, result.output
    assert not _wrong_pairs(project, timeline), _reasons(timeline)  # what is synchronized is right
    if result.exit_code == ExitCode.OK:
        assert not timeline.failed
    else:
        assert timeline.failed and re.search(cause, named), named
        for name in timeline.failed:  # a reason and a remedy on every camera that is not synchronized
            status = timeline.status(name)
            assert status.status in ("ambiguous", "failed") and status.reason and status.remedy


def test_an_error_never_quotes_a_file_of_the_system(project):
    edit_key(project, 1, "track", "/proc/self/environ")
    result, _ = _outcome(project)
    assert result.exit_code == ExitCode.BAD_INPUT
    assert not [value for value in os.environ.values() if len(value) > 8 and value in result.output]
    edit_key(project, 1, "track", "cam1/track.csv")
    TRAPS["track_is_passwd"](project)
    result, _ = _outcome(project)
    assert result.exit_code == ExitCode.BAD_INPUT and "not a CSV header" in result.output
    assert not [word for word in ("root", "bash", "daemon", "nologin") if word in result.output], result.output


def test_a_missing_file_is_named_before_any_stage_runs(project):
    (project / "cam2" / "camera.json").rename(project / "cam2" / "intrinsics.json")
    edit_key(project, 2, "camera", None)
    edit_key(project, 2, "calibration", {"intrinsics": "cam2/intrinsics.json", "gcp": "cam2/gcp.csv"})
    result = _cli("run", project / "project.toml", "-j", "1")
    assert result.exit_code == ExitCode.BAD_INPUT
    assert re.search(
        r"\[\[cameras\]\] 'cam2' \[cameras.calibration\] gcp: .*cam2/gcp.csv: file not found", result.output
    ), result.output
    assert not list((project / "work").rglob("*.manifest.json")) and "running" not in result.output


def test_one_video_given_for_two_cameras_is_bad_input(project):
    blank_video(project / "shared.mp4", 8, (64, 48))
    edit_key(project, 0, "video", "shared.mp4")
    edit_key(project, 1, "video", "shared.mp4")
    result, _ = _outcome(project)
    assert result.exit_code == ExitCode.BAD_INPUT
    assert "'cam1' video (shared.mp4) is the same file as the video of camera 'cam0'" in result.output


def test_an_fps_that_differs_from_the_video_container_is_a_stated_reason(project):
    blank_video(project / "cam0" / "video.mp4", 512, (640, 480), fps=30.0)
    edit_key(project, 0, "video", "cam0/video.mp4")
    edit_key(project, 0, "fps", 29.97)
    result, timeline = _outcome(project)
    assert result.exit_code == ExitCode.OK, result.output
    status = timeline.status("cam0")
    assert status.status == "weak" and [r.code for r in status.reasons] == ["fps_container"]
    assert "fps = 29.97 but the video's container says 30 fps" in status.reason
    assert not _wrong_pairs(project, timeline)


def test_the_answer_does_not_depend_on_the_log_time_unit(quick, tmp_path):
    """t in seconds, then x5 and x1000 with the unit declared: the same relations."""
    relations = {}
    for unit, factor in ((None, 1.0), (0.2, 5.0), ("ms", 1000.0)):
        root = tmp_path / f"unit-{factor:g}"
        shutil.copytree(quick, root)
        edit_trajectory(root, lambda t, xyz, factor=factor: (t * factor, xyz))
        if unit is not None:
            edit_key(root, None, "time_unit", unit)
        result, timeline = _outcome(root)
        assert result.exit_code == ExitCode.OK, result.output
        relations[factor] = timeline.pairs()
    for factor in (5.0, 1000.0):
        for key, relation in relations[1.0].items():
            assert relations[factor][key].alpha == pytest.approx(relation.alpha, abs=1e-6) and relations[factor][
                key
            ].beta == pytest.approx(relation.beta, abs=1e-3)


def test_terminal_report_status_and_timeline_agree_and_the_exit_code_follows(project):
    TRAPS["fps_twice"](project)
    run = _cli("run", project / "project.toml", "-j", "1", "-q")
    timeline = read_timeline(project / "work" / "timeline.json")
    statuses = timeline.statuses()
    assert run.exit_code == ExitCode.NOT_SYNCHRONIZED and statuses["cam1"].status == "failed"
    document = json.loads(_cli("status", project / "project.toml", "--json").output)
    written = json.loads((project / "work" / "timeline.json").read_text())["status"]
    report = (project / "work" / "report.html").read_text()
    for name, status in statuses.items():
        assert re.search(rf"^{name} +{status.status} ", run.output, re.M), run.output  # the terminal table
        if status.reason:
            assert f"{name}: {status.status}: {status.reason}" in run.output
        assert document["cameras"][name]["status"] == written[name]["status"] == status.status
        assert document["cameras"][name]["reason"] == written[name]["reason"] == status.reason
        assert re.search(
            rf"<td>{name}</td><td><span class=\"badge {status.status}\">{status.status}</span></td>", report
        )
    text = _cli("status", project / "project.toml")
    assert text.exit_code == ExitCode.NOT_SYNCHRONIZED
    for name, status in statuses.items():
        assert f"camera {name}: {status.status}" + (f": {status.reason}" if status.reason else "") in text.output


needs_real = pytest.mark.skipif(not REAL.is_dir(), reason="the real flight (../shared/real/drone2) is not here")


@pytest.fixture
def real(tmp_path) -> Path:
    root = tmp_path / "drone2"
    shutil.copytree(REAL, root, ignore=shutil.ignore_patterns("work"))
    return root


@needs_real
def test_the_real_flight_with_t_in_fifths_of_a_second_says_so_and_declared_gives_the_same_answer(real, tmp_path):
    result, reference = _outcome(real)
    assert result.exit_code == ExitCode.OK and not _wrong_pairs(real, reference)
    edit_trajectory(real, lambda t, xyz: (t * 5.0, xyz))
    result, _ = _outcome(real)
    assert result.exit_code == ExitCode.BAD_INPUT and re.search(
        r"column t: not seconds: .*sample numbers at 5 Hz\?\); set \[target\] time_unit = 0\.2$", result.output, re.M
    ), result.output
    edit_key(real, None, "time_unit", 0.2)
    result, timeline = _outcome(real)
    assert result.exit_code == ExitCode.OK, result.output
    for key, relation in reference.pairs().items():
        assert timeline.pairs()[key].beta == pytest.approx(relation.beta, abs=0.05)


@needs_real
@pytest.mark.parametrize("trap", ["reversed_in_time", "feet", "log_ends_early", "poses_swapped"])
def test_the_real_flight_with_a_trap_is_never_wrong(real, trap):
    TRAPS[trap](real)
    result, timeline = _outcome(real)
    assert result.exit_code in (ExitCode.NOT_SYNCHRONIZED, ExitCode.BAD_INPUT), result.output
    if timeline is not None:
        assert not _wrong_pairs(real, timeline), _reasons(timeline)


def test_project_files_round_trip(quick, tmp_path):
    """The trap helpers rewrite project.toml as it was."""
    root = tmp_path / "copy"
    shutil.copytree(quick, root)
    before = read_project(root)
    write_project(root, before)
    assert read_project(root) == before
    edit_camera(root, 0, lambda data: None)
    assert np.allclose(
        json.loads((root / "cam0" / "camera.json").read_text())["K"],
        json.loads((quick / "cam0" / "camera.json").read_text())["K"],
    )
