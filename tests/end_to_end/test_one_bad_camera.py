"""A copy of a small raw project (what ``tlsync demo`` writes, smaller) with one camera's file changed."""

import re
import shutil

import pytest
from click.testing import CliRunner

from data_fixtures.raw_project import SMALL, make_raw_project
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.sync.timeline import read_timeline

pytestmark = pytest.mark.slow  # minutes of decoding and tracking: CI's slow tier


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def raw_source(tmp_path_factory):
    project_file, scene = make_raw_project(tmp_path_factory.mktemp("raw") / "project", SMALL)
    return project_file.parent


@pytest.fixture
def raw_project(raw_source, tmp_path):
    shutil.copytree(raw_source, tmp_path / "project")
    return tmp_path / "project"


def _truncate(video, fraction: float) -> None:
    data = video.read_bytes()
    video.write_bytes(data[: int(len(data) * fraction)])


def test_a_truncated_video_is_a_tlsync_warning_that_quiet_silences(raw_project):
    _truncate(raw_project / "cam2" / "video.mp4", 0.6)
    toml = raw_project / "project.toml"
    result = _cli("track", toml, "--camera", "cam2", "-j", "1")
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.output.splitlines() if "video truncated" in line]
    assert len(warnings) == 1 and warnings[0].startswith("warning: track/cam2: ") and "video.mp4" in warnings[0], (
        result.output
    )
    assert "TruncatedVideoWarning" not in result.output and "warnings.warn" not in result.output
    quiet = _cli("track", toml, "--camera", "cam2", "-j", "1", "--quiet")
    assert quiet.exit_code == 0 and "video truncated" not in quiet.output, quiet.output


def test_parallel_workers_draw_no_bars_of_their_own(raw_project, monkeypatch):
    monkeypatch.setattr("tlsync_pipeline.cli.console.stderr_is_terminal", lambda: True)  # as in a terminal
    result = _cli("track", raw_project / "project.toml", "-j", "2")
    assert result.exit_code == 0, result.output
    assert "per-camera tasks" in result.output  # one bar, drawn by the calling process
    assert "video.mp4)" not in result.output  # the tracker's own bar is titled "cam0 (video.mp4)"


def test_a_camera_whose_video_never_shows_the_target_does_not_block_the_others(raw_project):
    """cam2's video without the target, then with a single frame: cam2 is reported, cam0 and cam1 synchronized and
    exported.
    """
    import numpy as np

    from data_fixtures.video import render_video

    toml = raw_project / "project.toml"
    video = raw_project / "cam2" / "video.mp4"
    for n_frames in (SMALL.n_frames[2], 1):
        render_video(
            video,
            n_frames=n_frames,
            image_size=SMALL.image_size,
            fps=15.0,
            positions=np.full((n_frames, 2), np.nan),
            distractor=False,
        )
        result = _cli("run", toml, "-j", "2", "-q")
        assert result.exit_code == 1, result.output
        failures = [line for line in result.output.splitlines() if "cam2" in line and "never found" in line]
        assert len(failures) == 1 and f"{video}: the target was never found" in failures[0], result.output
        timeline = read_timeline(raw_project / "work" / "timeline.json")
        assert timeline.names == ["cam0", "cam1"] and list(timeline.failed) == ["cam2"]
        offsets = (raw_project / "work" / "exports" / "offsets.csv").read_text()
        assert "cam1" in offsets and "cam2" not in offsets


def test_a_truncated_video_is_carried_into_the_timeline_and_the_frame_map(raw_project):
    import csv

    _truncate(raw_project / "cam1" / "video.mp4", 0.8)
    result = _cli("run", raw_project / "project.toml", "-j", "2")
    assert result.exit_code == 0, result.output  # every camera synchronized: a warning, not a failure
    warning = [
        line
        for line in result.output.splitlines()
        if line.startswith("warning: track/cam1: ") and "video truncated" in line
    ]
    assert len(warning) == 1, result.output
    frames = int(warning[0].split(" frames of ")[0].rsplit(" ", 1)[1])  # "..., N frames of M announced"
    timeline = read_timeline(raw_project / "work" / "timeline.json")
    assert "truncated" in timeline.cameras["cam1"].flags and "truncated" not in (timeline.cameras["cam0"].flags or ())
    assert re.search(r"^cam1: weak: .*the video ends before its announced end", result.output, re.M), (
        result.output
    )  # the camera's status
    assert "truncated" in (raw_project / "work" / "report.md").read_text()
    with open(raw_project / "work" / "exports" / "frame_map.csv", newline="") as handle:
        cam1_frames = [int(row["frame"]) for row in csv.DictReader(handle) if row["camera"] == "cam1"]
    assert max(cam1_frames) == frames - 1 and len(cam1_frames) == frames


def test_a_camera_that_cannot_be_calibrated_does_not_block_the_others(raw_project):
    gcp = raw_project / "cam2" / "gcp.csv"
    lines = gcp.read_text().splitlines()
    name, u, rest = lines[1].split(",", 2)
    lines[1] = f"{name},9999,{rest}"  # a pixel far outside the 320x240 image
    gcp.write_text("\n".join(lines) + "\n")
    result = _cli("run", raw_project / "project.toml", "-j", "2", "-q")
    assert result.exit_code == 2, result.output  # bad input, the most serious outcome of the run
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and errors[0].startswith("error: calibrate/cam2: ") and "gcp.csv:2" in errors[0], (
        result.output
    )
    timeline = read_timeline(raw_project / "work" / "timeline.json")
    assert timeline.names == ["cam0", "cam1"]
    assert timeline.failed["cam2"].startswith("calibrate/cam2 failed: ") and "gcp.csv:2" in timeline.failed["cam2"]
    assert "cam1" in (raw_project / "work" / "exports" / "offsets.csv").read_text()
    assert (raw_project / "work" / "render" / "votes_cam1.png").exists()
