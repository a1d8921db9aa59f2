"""timeline.json: typed camera lines written and read back; pairs of variable-frame-rate cameras are
marked approximate.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from data_fixtures import make_scene
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.outputs.summary import format_table
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import LinePose, LogCorrection, read_timeline, write_timeline
from tlsync_pipeline.trajectory import Trajectory


def _timeline(**scene_args):
    scene = make_scene(0, lines=((2.0, 45.61), (1.5, 4.37)), tracking_noise_px=1.0, **scene_args)
    inputs = {n: CameraInput(scene.cameras[n], scene.tracks[n], scene.cameras[n].fps) for n in scene.cameras}
    return synchronize(inputs, scene.trajectory, SyncParams())[0]


def test_camera_lines_read_back_typed(tmp_path):
    timeline = _timeline(frame_time_jitter=0.1)
    write_timeline(timeline, tmp_path / "timeline.json")
    back = read_timeline(tmp_path / "timeline.json")
    for name, line in timeline.cameras.items():
        again = back.cameras[name]
        assert again.clock == line.clock and line.clock.kind == "time_s"
        assert again.line_search == line.line_search and again.refinement == line.refinement
        assert (again.flags, again.warnings, again.refined) == (line.flags, line.warnings, line.refined)
        np.testing.assert_array_equal(again.cov, line.cov)
        assert (again.alpha, again.beta, again.fps) == (line.alpha, line.beta, line.fps)
    assert back.relation("cam0", "cam1") == timeline.relation("cam0", "cam1")
    data = json.loads((tmp_path / "timeline.json").read_text())
    camera = data["cameras"]["cam1"]
    assert {"clock", "clock_fps", "clock_origin_s", "time_jitter_frames", "line_search", "refinement", "cov"} <= set(
        camera
    )
    pair = data["pairs"]["cam0->cam1"]
    assert pair["approximate"] is True and pair["exact"] == "exports/frame_map.csv"
    assert "variable frame rate: cam0, cam1: starts in frames are approximate" in format_table(back)


def test_constant_rate_cameras_keep_frame_indices_and_exact_pairs(tmp_path):
    timeline = _timeline()
    write_timeline(timeline, tmp_path / "timeline.json")
    data = json.loads((tmp_path / "timeline.json").read_text())
    assert not {"clock", "clock_origin_s"} & set(data["cameras"]["cam0"])
    assert "approximate" not in data["pairs"]["cam0->cam1"] and "variable frame rate" not in format_table(timeline)
    frames = np.arange(0.0, 500.0, 7.0)
    # Without presentation times, match and relation are the same mapping.
    np.testing.assert_allclose(
        timeline.match("cam0", "cam1", frames), timeline.relation("cam0", "cam1")(frames), rtol=0, atol=1e-9
    )


def test_a_malformed_camera_entry_names_the_file(tmp_path):
    write_timeline(_timeline(), tmp_path / "timeline.json")
    data = json.loads((tmp_path / "timeline.json").read_text())
    data["cameras"]["cam0"]["line_search"] = {"alpha": 1.0}
    (tmp_path / "timeline.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="timeline.json: not a tlsync timeline"):
        read_timeline(tmp_path / "timeline.json")


def _rotation(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_the_pose_a_line_was_fitted_with_and_the_logs_correction_read_back(tmp_path):
    timeline = _timeline()
    pose = LinePose(_rotation(0.3), np.array([1.0, -2.0, 30.0]), "second_pass+bias_refit")
    offsets = np.array([[0.5, -0.2, 0.1], [1.0, 0.0, -0.3], [0, 0, 0]])
    correction = LogCorrection(np.array([0.0, 50.0, 400.0]), offsets, "second_pass+bias_refit")
    lines = {**timeline.cameras, "cam1": replace(timeline.cameras["cam1"], pose=pose)}
    write_timeline(replace(timeline, cameras=lines, log_correction=correction), tmp_path / "timeline.json")
    data = json.loads((tmp_path / "timeline.json").read_text())
    assert "pose" not in data["cameras"]["cam0"] and data["cameras"]["cam1"]["pose"]["source"] == pose.source
    assert data["log_correction"]["source"] == "second_pass+bias_refit"
    np.testing.assert_allclose(data["cameras"]["cam1"]["pose"]["camera_center_m"], -pose.R.T @ pose.t)
    back = read_timeline(tmp_path / "timeline.json")
    assert back.cameras["cam0"].pose is None and back.cameras["cam1"].pose is not None
    np.testing.assert_array_equal(back.cameras["cam1"].pose.R, pose.R)
    np.testing.assert_array_equal(back.cameras["cam1"].pose.t, pose.t)
    assert back.cameras["cam1"].pose.source == pose.source and back.log_correction is not None
    assert back.log_correction.source == "second_pass+bias_refit"
    np.testing.assert_array_equal(back.log_correction.at(np.array([25.0])), [[0.75, -0.1, -0.1]])


def test_a_logs_correction_older_versions_wrote_reads_as_the_second_passes(tmp_path):
    """Before the kept refit's bias was recorded, log_correction was the later passes' alone: source "second_pass"
    (read the same without one); a source no version writes is malformed."""
    correction = LogCorrection(np.array([0.0, 50.0]), np.array([[0.5, -0.2, 0.1], [1.0, 0.0, -0.3]]))
    write_timeline(replace(_timeline(), log_correction=correction), tmp_path / "timeline.json")
    data = json.loads((tmp_path / "timeline.json").read_text())
    assert data["log_correction"]["source"] == "second_pass"
    del data["log_correction"]["source"]
    (tmp_path / "timeline.json").write_text(json.dumps(data))
    back = read_timeline(tmp_path / "timeline.json").log_correction
    assert back is not None and back.source == "second_pass"
    np.testing.assert_array_equal(back.offset_m, correction.offset_m)
    data["log_correction"]["source"] = "survey"
    (tmp_path / "timeline.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="timeline.json: not a tlsync timeline"):
        read_timeline(tmp_path / "timeline.json")


def test_a_timeline_without_a_pose_or_a_correction_reads_as_before(tmp_path):
    """A timeline.json written before the pose block and the log's correction existed (or by a run without them)."""
    write_timeline(_timeline(), tmp_path / "timeline.json")
    data = json.loads((tmp_path / "timeline.json").read_text())
    assert "log_correction" not in data and not any("pose" in c for c in data["cameras"].values())
    back = read_timeline(tmp_path / "timeline.json")
    assert back.log_correction is None and all(line.pose is None for line in back.cameras.values())


def test_a_malformed_pose_block_names_the_file(tmp_path):
    write_timeline(_timeline(), tmp_path / "timeline.json")
    data = json.loads((tmp_path / "timeline.json").read_text())
    data["cameras"]["cam0"]["pose"] = {"R": [[1, 0], [0, 1]], "t": [0, 0, 0], "source": "target"}
    (tmp_path / "timeline.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="timeline.json: not a tlsync timeline"):
        read_timeline(tmp_path / "timeline.json")


def test_the_logs_correction_is_linear_between_its_knots_and_constant_beyond():
    correction = LogCorrection(np.array([10.0, 20.0]), np.array([[0.0, 1.0, 2.0], [1.0, 3.0, 2.0]]))
    log = Trajectory(np.array([0.0, 15.0, 30.0]), np.zeros((3, 3)), 10.0, 5.0)
    corrected = correction.applied(log)
    np.testing.assert_array_equal(corrected.xyz, [[0.0, 1.0, 2.0], [0.5, 2.0, 2.0], [1.0, 3.0, 2.0]])
    assert (corrected.rate, corrected.t0) == (10.0, 5.0) and corrected.sample is log.sample


def test_two_corrections_added_are_the_one_then_the_other_on_the_log_it_corrected():
    """A later pass's correction (fitted on the log the first corrected) added to the first: one correction that
    corrects the log as both in turn, at any sample (on, between and beyond either's knots)."""
    first = LogCorrection(np.array([10.0, 20.0]), np.array([[0.0, 1.0, 2.0], [1.0, 3.0, 2.0]]))
    then = LogCorrection(np.array([5.0, 15.0, 40.0]), np.array([[0.5, 0.0, -1.0], [0.0, 0.0, 0.0], [-2.0, 1.0, 0.0]]))
    log = Trajectory(np.linspace(0.0, 50.0, 101), np.zeros((101, 3)), 10.0, 5.0)
    both = first.plus(then)
    np.testing.assert_allclose(both.applied(log).xyz, then.applied(first.applied(log)).xyz, atol=1e-12)
    np.testing.assert_array_equal(both.knots, [5.0, 10.0, 15.0, 20.0, 40.0])
    assert both.source == "second_pass"  # two passes' corrections: still the passes'
    refit = LogCorrection(then.knots, then.offset_m, "bias_refit")
    assert first.plus(refit).source == both.plus(refit).source == "second_pass+bias_refit"
    joint = LogCorrection(then.knots, then.offset_m, "log_bias")
    assert first.plus(joint).source == "second_pass+log_bias"
    assert LogCorrection.from_dict(first.plus(joint).to_dict()).source == "second_pass+log_bias"


def test_a_line_pose_puts_its_pose_on_a_camera_without_one():
    scene = make_scene(0)
    camera = scene.cameras["cam0"]
    pose = LinePose.of(camera, "target")
    unposed = camera.without_pose()
    assert not unposed.posed
    drawn = pose.on(unposed)
    assert drawn.posed and drawn.image_size == camera.image_size
    points = scene.trajectory.xyz[:50]
    np.testing.assert_allclose(drawn.project(points)[0], camera.project(points)[0])
