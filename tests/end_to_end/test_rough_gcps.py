"""The raw demo (`tlsync demo`'s project) with its GCPs surveyed 0.5 m off, run with the defaults: every camera is
synchronized, as without any GCP; the survey's error is measured from the points, not taken from gcp_sigma_m."""

import json

import pytest
from click.testing import CliRunner

from data_fixtures.raw_project import RawProjectSpec, make_raw_project
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.sync.timeline import eps_t, read_timeline, read_truth


@pytest.mark.slow
def test_the_raw_demo_with_gcps_half_a_metre_off_synchronizes_every_camera(tmp_path):
    project_file, scene = make_raw_project(tmp_path / "demo", RawProjectSpec(gcp_noise_m=0.5, gcp_draw=3))
    result = CliRunner().invoke(main, ["run", str(project_file), "-j", "1", "-q"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    work = project_file.parent / "work"
    timeline = read_timeline(work / "timeline.json")
    truth, n_frames = read_truth(project_file.parent / "truth.json")
    assert sorted(timeline.cameras) == sorted(scene.true_cameras) and not timeline.failed
    worst = max(
        eps_t(timeline.relation(*key.split("->")), relation, n_frames[key.split("->")[0]])
        for key, relation in truth.items()
    )
    assert worst <= 0.15
    for name in scene.true_cameras:
        target = json.loads((work / "cameras" / name / "calibration_report.json").read_text())["target_pose"]
        assert target["source"] in ("gcp+target", "target")
        assert (
            target["gcp_sigma_stated_m"] == 1.0 and 0.1 < target["gcp_sigma_m"] < 1.0
        )  # measured: 0.5 m per horizontal axis
