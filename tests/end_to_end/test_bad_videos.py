"""A copy of a small raw project (what ``tlsync demo`` writes, smaller) with one video changed."""

import shutil

import pytest
from click.testing import CliRunner

from data_fixtures.raw_project import SMALL, make_raw_project
from tlsync_pipeline.cli.main import main


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
    assert len(warnings) == 1 and warnings[0].startswith("warning: track/cam2: ") and "video.mp4" in warnings[0], result.output
    assert "TruncatedVideoWarning" not in result.output and "warnings.warn" not in result.output
    quiet = _cli("track", toml, "--camera", "cam2", "-j", "1", "--quiet")
    assert quiet.exit_code == 0 and "video truncated" not in quiet.output, quiet.output


def test_parallel_workers_draw_no_bars_of_their_own(raw_project):
    result = _cli("track", raw_project / "project.toml", "-j", "2")
    assert result.exit_code == 0, result.output
    assert "per-camera tasks" in result.output
    assert "video.mp4)" not in result.output  # the tracker's own bar is titled "cam0 (video.mp4)"
