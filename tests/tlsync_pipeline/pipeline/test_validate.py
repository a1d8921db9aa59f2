"""What is checked before any stage runs: each file a run reads, by its key, and the files against each other."""

from __future__ import annotations

import numpy as np
import pytest

from data_fixtures.traps import edit_key
from data_fixtures.video import blank_video
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.validate import validate_project


def _validate(project_dir, used=None):
    validate_project(load_project(project_dir / "project.toml"), used)


def test_a_good_project_passes(project_dir):
    _validate(project_dir)


def test_a_video_of_another_size_than_the_camera_is_named(project_dir):
    blank_video(project_dir / "cam0" / "video.mp4", 600, (320, 240))
    edit_key(project_dir, 0, "video", "cam0/video.mp4")
    with pytest.raises(
        InputError,
        match=r"\[\[cameras\]\] 'cam0' camera: .*image_size \[640, 480\] but the camera's video video.mp4 is 320 x 240",
    ):
        _validate(project_dir)


def test_the_same_content_under_two_names_is_one_file_for_two_cameras(project_dir):
    (project_dir / "cam1" / "camera.json").write_bytes((project_dir / "cam0" / "camera.json").read_bytes())
    with pytest.raises(
        InputError, match=r"'cam1' camera \(cam1/camera.json\) is the same file as the camera of camera 'cam0'"
    ):
        _validate(project_dir)


def test_only_the_files_of_the_tasks_about_to_run_are_read(project_dir):
    (project_dir / "trajectory.csv").unlink()
    project = load_project(project_dir / "project.toml")
    _validate(project_dir, {project.camera("cam0").camera})  # a run that reads cam0's camera.json only
    with pytest.raises(InputError, match=r"\[target\] trajectory: .*trajectory.csv: file not found"):
        _validate(project_dir)


def test_a_trajectory_in_milliseconds_is_named_with_its_fix(project_dir):
    t = np.arange(0.0, 120.0, 0.2)
    rows = "\n".join(f"{1000 * v:.1f},{1.4 * v:.3f},0.0,1.5" for v in t)  # a walker at 5 Hz, t written in ms
    (project_dir / "trajectory.csv").write_text("t,x,y,z\n" + rows + "\n")
    with pytest.raises(
        InputError,
        match=r"\[target\] trajectory: .*column t: in seconds, one sample every 200 s .*\(milliseconds\?\); set "
        r'\[target\] time_unit = "ms"',
    ):
        _validate(project_dir)
    edit_key(project_dir, None, "time_unit", "ms")
    _validate(project_dir)


def test_a_video_downscaled_from_its_calibration_is_named(project_dir):
    """A camera calibrated at 640 x 480 whose video is a half-size copy: named before any stage runs, not a pose that
    fails.
    """
    (project_dir / "cam0" / "camera.json").rename(project_dir / "cam0" / "intrinsics.json")
    edit_key(project_dir, 0, "camera", None)
    edit_key(project_dir, 0, "calibration", {"intrinsics": "cam0/intrinsics.json"})
    blank_video(project_dir / "cam0" / "video.mp4", 600, (320, 240))
    edit_key(project_dir, 0, "video", "cam0/video.mp4")
    with pytest.raises(
        InputError,
        match=r"'cam0' video: .*video.mp4: 320 x 240, but the intrinsics are of 640 x 480 images "
        r"\(0.5 of their size: a downscaled copy\?\); give the original video",
    ):
        _validate(project_dir)


def test_a_trajectory_partly_at_another_rate_is_refused_with_its_fix(project_dir):
    fast = np.arange(0.0, 60.0, 0.01)  # 100 Hz, then 20 s at 15 Hz, then 100 Hz again: the 15 Hz part sits between gaps
    times = np.r_[fast, 60.0 + np.arange(1, 300) / 15.0, 80.0 + fast]
    rows = "\n".join(f"{v:.6f},{1.4 * v:.3f},0.0,1.5" for v in times)
    (project_dir / "trajectory.csv").write_text("t,x,y,z\n" + rows + "\n")
    with pytest.raises(
        InputError,
        match=r"\[target\] trajectory: .*299 samples in a row sit between gaps on the grid of 100 Hz .*resample it "
        r"onto one rate",
    ):
        _validate(project_dir)
    dropouts = np.delete(fast, np.arange(5, len(fast), 7))  # a sample lost every 0.07 s: gaps, no stretch left out
    (project_dir / "trajectory.csv").write_text(
        "t,x,y,z\n" + "\n".join(f"{v:.6f},{1.4 * v:.3f},0.0,1.5" for v in dropouts) + "\n"
    )
    _validate(project_dir)
