"""The command line end to end: exit codes, messages, timeline.json."""

import json
import re

import numpy as np
import pytest
from click.testing import CliRunner

from tlsync_pipeline.cli.main import main


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_run_writes_timeline_and_prints_table(project_dir):
    result = _run("run", project_dir / "project.toml", "--truth", project_dir / "truth.json")
    assert result.exit_code == 0, result.output
    assert "cam0" in result.output and "eps_t" in result.output
    data = json.loads((project_dir / "work" / "timeline.json").read_text())
    assert set(data["cameras"]) == {"cam0", "cam1"}
    assert data["cameras"]["cam0"]["alpha"] == pytest.approx(2.0, abs=0.01)
    assert data["pairs"]["cam0->cam1"]["beta"] == pytest.approx(41.0, abs=0.5)
    assert data["target"]["rate"] == pytest.approx(15.0)
    assert data["line"]["direction"][0] == 1.0


def test_work_option_and_a_folder_as_the_project(project_dir, tmp_path):
    out = tmp_path / "elsewhere"
    assert _run("run", project_dir, "--work", out).exit_code == 0
    assert (out / "timeline.json").exists()
    refused = _run("run", project_dir, "--out", out)
    assert refused.exit_code == 2 and refused.output.startswith(
        "error: --out: names the file a standalone command writes"
    ), refused.output


def _replace(path, old, new):
    path.write_text(path.read_text().replace(old, new, 1))


@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda d: (d / "cam0" / "track.csv").unlink(), "track.csv: file not found"),
        (lambda d: (d / "cam0" / "track.csv").write_text("frame,x,y\n"), "the track is empty"),
        (lambda d: (d / "cam0" / "track.csv").write_text("frame,x,y\n0,nan,2\n"), r"track.csv:2: column 'x'"),
        (
            lambda d: (d / "cam0" / "track.csv").write_text("frame,x,y\n0,1,2\n1,one,2\n"),
            r"track.csv:3: column 'x': not a number",
        ),
        (lambda d: _replace(d / "cam1" / "camera.json", '"t": [', '"t": [[1], '), "field 't'"),
        (
            lambda d: (d / "cam1" / "camera.json").write_text(
                json.dumps(
                    {**json.loads((d / "cam1" / "camera.json").read_text()), "K": [[0, 0, 0], [0, 0, 0], [0, 0, 1]]}
                )
            ),
            "singular",
        ),
        (lambda d: (d / "trajectory.csv").write_text("t,x,y,z\n0,1,2,3\n"), "at least 2 are needed"),
        (lambda d: _replace(d / "project.toml", 'name = "cam1"', 'name = "cam0"'), "duplicate camera name"),
        (lambda d: _replace(d / "project.toml", "eps_px", "epsilon_px"), "did you mean 'eps_px'"),
    ],
)
def test_bad_input_exits_2_with_a_clear_message(project_dir, damage, message):
    damage(project_dir)
    before = (project_dir / "work").exists()
    result = _run("run", project_dir / "project.toml")
    assert result.exit_code == 2, result.output
    assert "error:" in result.output and re.search(message, result.output), result.output
    assert "Traceback" not in result.output
    assert (project_dir / "work").exists() == before


def test_failed_run_keeps_the_previous_timeline(project_dir):
    assert _run("run", project_dir / "project.toml").exit_code == 0
    good = (project_dir / "work" / "timeline.json").read_text()
    (project_dir / "cam0" / "track.csv").write_text("frame,x,y\n0,1\n")
    assert _run("run", project_dir / "project.toml").exit_code == 2
    assert (project_dir / "work" / "timeline.json").read_text() == good


def test_unsynchronizable_camera_exits_1_and_says_why(project_dir):
    rows = "\n".join(f"{f},{2 + f % 3},{2.0}" for f in range(50))
    (project_dir / "cam1" / "track.csv").write_text("frame,x,y\n" + rows + "\n")
    result = _run("run", project_dir / "project.toml", "--truth", project_dir / "truth.json")
    for pair in ("cam0->cam1", "cam1->cam0"):  # the failed camera's pairs are in the eps_t table, as failed
        assert re.search(rf"^{pair} .* failed: cam1 not synchronized$", result.output, re.M), result.output
    assert result.exit_code == 1
    assert "cam1" in result.output and "closest is" in result.output
    data = json.loads((project_dir / "work" / "timeline.json").read_text())
    assert list(data["cameras"]) == ["cam0"] and "cam1" in data["failed"]


def test_demo_recovers_the_truth(tmp_path):
    result = _run("demo", "--quick", tmp_path / "demo")
    assert result.exit_code == 0, result.output
    worst = float(result.output.split("worst eps_t:")[1].split()[0])
    assert np.isfinite(worst) and worst <= 2.0


def test_tlsync_alone_prints_the_help():
    result = _run()
    assert (
        result.exit_code == 0
        and result.output.startswith("Usage:")
        and "Commands:" in result.output
        and "run" in result.output
    )
