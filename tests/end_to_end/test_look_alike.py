"""A look-alike on the target's path through `tlsync run`: the camera's reason names both starts, and the project's
pick_start_s picks the target's mover (the identify stage), synchronized on its line."""

import re

import numpy as np
from click.testing import CliRunner

from calibration.camera import write_camera
from data_fixtures import make_scene
from tests.look_alikes import followed_by_a_look_alike, wandering_log
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.sync.timeline import read_timeline
from tlsync_pipeline.trajectory import write_trajectory
from trackers.detections import write_detections


def _project(folder, pick=None):
    """cam0 of scene 0 bringing every mover (the target on 40 % of its frames, a look-alike 0.4 s ahead of it on
    all of them) and the log whose projection wanders about the target; ``pick``: pick_start_s, or None."""
    scene = make_scene(seed=0)
    camera = scene.cameras["cam0"]
    write_camera(camera, folder / "cam0.json")
    write_detections(followed_by_a_look_alike(scene, "cam0", lag=-12, seen=0.4, seed=0), folder / "movers.csv")
    write_trajectory(wandering_log(scene, "cam0", 4.0, 0), folder / "trajectory.csv")
    lines = ["[target]", 'trajectory = "trajectory.csv"', "", "[[cameras]]", 'name = "cam0"', 'camera = "cam0.json"']
    lines += ['detections = "movers.csv"', f"fps = {camera.fps!r}"]
    lines += [f"pick_start_s = {pick!r}"] if pick is not None else []
    (folder / "project.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return scene, folder / "project.toml"


def test_a_look_alike_ahead_is_named_with_both_starts_and_the_pick_takes_the_target(tmp_path):
    scene, project = _project(tmp_path)
    CliRunner().invoke(main, ["run", str(project), "--quiet"], catch_exceptions=False)
    status = read_timeline(tmp_path / "work" / "timeline.json").status("cam0")
    reason = next(r for r in status.reasons if r.code in ("another_mover", "ambiguous"))
    starts = [float(s) for s in re.findall(r"at (-?[0-9.]+) s of the log", reason.text)]
    truth = scene.lines["cam0"]
    start = -truth.beta / truth.alpha / scene.trajectory.rate
    assert len(starts) == 2 and min(abs(s - start) for s in starts) < 1.0 / scene.cameras["cam0"].fps
    picked = tmp_path / "picked"
    picked.mkdir()
    _, project = _project(picked, pick=start)
    result = CliRunner().invoke(main, ["run", str(project), "--quiet"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    line = read_timeline(picked / "work" / "timeline.json").cameras["cam0"]
    middle = (float(np.median(scene.tracks["cam0"].frame)) - truth.beta) / truth.alpha
    assert abs((line.alpha - truth.alpha) * middle + line.beta - truth.beta) < 1.0
    assert "picked" in line.flags
