"""The real flight without poses under a drone's GNSS, run as a user would: a project of camera.json files without R,
t, the hand-labelled tracks and the log with a consumer receiver's error, declared ``log_model = "drone"``. The
calibrate stage poses every camera from the target under that model, and the stages give the answer synchronize()
gives on the same files."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from calibration.camera import Camera, read_camera, write_camera
from data_fixtures.log_error import PRESETS as FIXTURE_LOGS
from data_fixtures.log_error import log_errors
from data_fixtures.logged_project import write_logged_project
from tests.real_data import REAL_DATA, drone2_hovers, without_poses
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.outputs.plots import track_residuals
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.sync import load_inputs
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import CameraLine, eps_t, read_timeline, read_truth
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

REAL = REAL_DATA / "drone2"


@pytest.mark.slow
@pytest.mark.skipif(
    not (REAL / "project.toml").exists(), reason="the real flight (TLSYNC_REAL_DATA/drone2) is not here"
)
def test_the_real_flight_without_poses_under_a_drone_gnss_runs_through_the_stages_as_synchronize_does(tmp_path):
    project = load_project(REAL / "project.toml")
    cameras, trajectory = load_inputs(project)
    errors, _ = log_errors(np.random.default_rng(3), trajectory.sample / trajectory.rate, FIXTURE_LOGS["drone"])
    unposed = {
        n: replace(c, camera=replace(c.camera, R=np.eye(3), t=np.zeros(3), to_estimate=("pose",), pose_info=None))
        for n, c in cameras.items()
    }
    logged = replace(trajectory, xyz=trajectory.xyz + errors)
    project_file = write_logged_project(tmp_path / "flight", unposed, logged, "drone")

    result = CliRunner().invoke(main, ["run", str(project_file), "-j", "1", "-q"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    work = project_file.parent / "work"
    staged = read_timeline(work / "timeline.json")
    written = load_project(project_file)
    direct, _ = synchronize(*load_inputs(written), written.sync, log_model=LOG_MODELS["drone"])

    assert sorted(staged.cameras) == sorted(direct.cameras) == sorted(cameras), (staged.failed, direct.failed)
    truth = json.loads((REAL / "truth.json").read_text())["cameras_to_target"]
    for name, line in staged.cameras.items():
        report = json.loads((work / "cameras" / name / "calibration_report.json").read_text())["target_pose"]
        assert report["source"] == "target" and report["timing"]["bias_beta"] is not None  # the log's bias fitted
        sigma = np.sqrt(line.cov[1, 1])
        assert abs(line.beta - direct.cameras[name].beta) <= 0.05 * sigma, name  # seeds 0-3: to the digit
        assert np.sqrt(direct.cameras[name].cov[1, 1]) == pytest.approx(sigma, rel=0.05), name
        assert abs(line.beta - truth[name]["beta"]) <= 3 * sigma, name
    pairs, n_frames = read_truth(REAL / "truth.json")
    errors_t = [eps_t(staged.relation(*k.split("->")), r, n_frames[k.split("->")[0]]) for k, r in pairs.items()]
    assert np.median(errors_t) <= 2.0

    # one pass, its refit of the poses kept: the pictures draw the refitted poses on the log corrected by the bias
    # they were refitted on, which the track lies closer to than to the log as logged (seeds 0-1 through
    # synchronize: 6-11 px against 40-98)
    correction = staged.log_correction
    assert correction is not None and correction.source == "bias_refit", correction
    corrected = correction.applied(logged)
    paths = _player_paths(work)
    for name, line in staged.cameras.items():
        assert line.pose is not None and line.pose.source == "bias_refit", name
        drawn, track = line.pose.on(read_camera(work / "cameras" / name / "camera.json")), cameras[name].track
        assert _median_residual(drawn, track, corrected, line) < 0.5 * _median_residual(drawn, track, logged, line)
        path = paths[name]
        np.testing.assert_allclose(path[:, 1:], _projected(drawn, corrected, path[:, 0]), atol=0.06)


def _player_paths(work: Path) -> dict[str, np.ndarray]:
    """Per camera the player's projected path in report.html: rows (sample, u, v) where it is drawn (pixels)."""
    html = (work / "report.html").read_text()
    player = json.loads(html.split('id="tlsync-player-data">', 1)[1].split("</script>", 1)[0])
    out = {}
    for entry in player["cameras"]:
        path = entry["path"]
        uv = np.array([np.nan if v is None else v / 10.0 for v in path["uv"]]).reshape(-1, 2)
        samples = path["start"] + path["step"] * np.arange(len(uv))
        drawn = np.isfinite(uv).all(axis=1)
        out[entry["name"]] = np.column_stack([samples[drawn], uv[drawn]])
    return out


def _projected(camera: Camera, log: Trajectory, samples: np.ndarray) -> np.ndarray:
    """(N, 2) pixels of the log's positions at grid ``samples`` under ``camera``."""
    index = np.searchsorted(log.sample, samples)
    assert np.allclose(log.sample[index], samples), "the player draws grid samples"
    return camera.project(log.xyz[index])[0]


def _median_residual(camera: Camera, track, log: Trajectory, line: CameraLine) -> float:
    """Median distance (pixels) of the tracked target from the log projected at the line's samples."""
    found = track_residuals(camera, track, PiecewiseTrajectory(log), line)
    return float(np.nanmedian(np.hypot(found.dx, found.dy)))


@pytest.mark.slow
@pytest.mark.skipif(
    not (REAL / "project.toml").exists(), reason="the real flight (TLSYNC_REAL_DATA/drone2) is not here"
)
def test_the_pose_the_second_pass_fitted_a_line_with_is_the_one_timeline_json_holds_and_the_report_draws(tmp_path):
    """drone2's hover-only tracks without poses under a drone's GNSS (seed 0): the calibrate stage poses the cameras
    (one fails not_upright), the sync's second pass searches every pose again on the log corrected for its bias. The
    poses it fitted the lines with are in timeline.json with that correction; the track lies closer to that log
    projected with them at the lines than to anything the calibrate stage's poses give; camera.json and
    calibration_report.json keep the calibrate stage's pose; the player draws the timeline's. A surveyed camera.json
    given afterwards re-runs the sync, and its camera is drawn with that pose again."""
    _, hovers = drone2_hovers()
    log = hovers.trajectory
    errors, _ = log_errors(np.random.default_rng(0), log.sample / log.rate, FIXTURE_LOGS["drone"])
    logged = replace(log, xyz=log.xyz + errors)
    folder = tmp_path / "hovers"
    project_file = write_logged_project(folder, without_poses(hovers.cameras), logged, "drone")
    result = CliRunner().invoke(main, ["run", str(project_file), "-j", "1", "-q"], catch_exceptions=False)
    work = folder / "work"
    timeline = read_timeline(work / "timeline.json")
    assert timeline.log_correction is not None and len(timeline.cameras) >= 3, timeline.failed
    # a camera the calibrate stage could not pose (cam1, not_upright) that the second pass synchronized is not failed
    assert not set(timeline.cameras) & set(timeline.failed)
    assert result.exit_code == (1 if timeline.failed else 0), result.output
    corrected = timeline.log_correction.applied(logged)
    paths = _player_paths(work)
    moved = []
    for name, line in timeline.cameras.items():
        assert line.pose is not None and line.pose.source.startswith("second_pass"), name
        calibrated = read_camera(work / "cameras" / name / "camera.json")
        drawn = line.pose.on(calibrated)
        track = hovers.cameras[name].track
        fitted = _median_residual(drawn, track, corrected, line)
        assert fitted < _median_residual(drawn, track, logged, line), name
        report = json.loads((work / "cameras" / name / "calibration_report.json").read_text())["target_pose"]
        if calibrated.posed:  # the calibrate stage's artefacts keep its own pose
            np.testing.assert_allclose(calibrated.center, report["camera_center_m"], atol=1e-6)
            moved.append(float(np.linalg.norm(line.pose.center - calibrated.center)))
            assert fitted < _median_residual(calibrated, track, logged, line), name
        path = paths[name]
        np.testing.assert_allclose(path[:, 1:], _projected(drawn, corrected, path[:, 0]), atol=0.06)
    assert max(moved) > 1.0  # the second pass moved a pose by metres

    surveyed = hovers.cameras["cam0"].camera  # drone2's surveyed pose, given in the project from now on
    write_camera(surveyed, folder / "cam0_camera.json")
    result = CliRunner().invoke(main, ["run", str(project_file), "-j", "1", "-q"], catch_exceptions=False)
    assert result.exit_code in (0, 1), result.output
    again = read_timeline(work / "timeline.json")
    assert "cam0" in again.cameras and again.cameras["cam0"].pose is None, again.failed
    path = _player_paths(work)["cam0"]
    log_drawn = logged if again.log_correction is None else again.log_correction.applied(logged)
    np.testing.assert_allclose(path[:, 1:], _projected(surveyed, log_drawn, path[:, 0]), atol=0.06)
