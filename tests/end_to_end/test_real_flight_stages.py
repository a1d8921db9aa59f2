"""The real flight without poses under a drone's GNSS, run as a user would: a project of camera.json files without R,
t, the hand-labelled tracks and the log with a consumer receiver's error, declared ``log_model = "drone"``. The
calibrate stage poses every camera from the target under that model, and the stages give the answer synchronize()
gives on the same files."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from data_fixtures.log_error import PRESETS as FIXTURE_LOGS
from data_fixtures.log_error import log_errors
from data_fixtures.logged_project import write_logged_project
from tests.real_data import REAL_DATA
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.sync import load_inputs
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import eps_t, read_timeline, read_truth

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
    project_file = write_logged_project(
        tmp_path / "flight", unposed, replace(trajectory, xyz=trajectory.xyz + errors), "drone"
    )

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
