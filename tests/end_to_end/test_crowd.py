"""Crowd scenes through `tlsync run`: the target found among look-alike walkers without an init box.

Raw projects (videos and camera.json files, a trajectory CSV) of two
surveillance-like views (10 and 5 fps, shifted starts) with distractor walkers
of the target's size, colour and speed that cross its path and occlude it; the
target leaves the views and comes back; H.264, noise and a lighting drop.
With 2 and 6 walkers per view both pairs are within half a frame and the
identified tracks stay on the target (bench/crowd.py runs 20 scenes per
count: docs/accuracy.md). An init box seeds the identity without detecting
the movers again.
"""

import dataclasses
import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from data_fixtures.crowd import CrowdSpec, write_crowd_project
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.sync.timeline import Relation, eps_t, read_timeline
from trackers.detections import read_detections, write_detections
from trackers.track import read_track

pytestmark = pytest.mark.slow  # minutes of decoding and tracking: CI's slow tier


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def _pair_errors(project_dir, timeline):
    truth = json.loads((project_dir / "truth.json").read_text())
    out = {}
    for key, value in truth["pairs"].items():
        a, b = key.split("->")
        out[key] = eps_t(timeline.relation(a, b), Relation(value["alpha"], value["beta"]), truth["n_frames"][a])
    return out


def _write_and_run(tmp_path_factory, distractors):
    directory = tmp_path_factory.mktemp(f"crowd{distractors}")
    project, crowd = write_crowd_project(directory, CrowdSpec(seed=0, distractors=distractors))
    result = _run("run", project, "--quiet")
    return directory, crowd, result


@pytest.fixture(scope="module")
def two_walkers(tmp_path_factory):
    return _write_and_run(tmp_path_factory, 2)


@pytest.fixture(scope="module")
def six_walkers(tmp_path_factory):
    return _write_and_run(tmp_path_factory, 6)


@pytest.fixture(scope="module")
def six_walkers_again(tmp_path_factory):
    directory = tmp_path_factory.mktemp("crowd6b")
    project, crowd = write_crowd_project(directory, CrowdSpec(seed=3, distractors=6))
    return directory, crowd, _run("run", project, "--quiet")


@pytest.fixture(scope="module", params=["two_walkers", "six_walkers", "six_walkers_again"])
def crowd_run(request):
    return request.getfixturevalue(request.param)


def test_both_pairs_within_half_a_frame(crowd_run):
    directory, _, result = crowd_run
    assert result.exit_code == 0, result.output
    timeline = read_timeline(directory / "work" / "timeline.json")
    errors = _pair_errors(directory, timeline)
    assert len(errors) == 2 and max(errors.values()) <= 0.5, errors


def test_identified_tracks_are_on_the_target(crowd_run):
    directory, crowd, _ = crowd_run
    timeline = read_timeline(directory / "work" / "timeline.json")
    for name, truth in crowd.truth.items():
        movers = read_detections(directory / "work" / "cameras" / name / "detections.csv")
        assert len(np.unique(movers.id)) > 20  # every mover, not one target
        track = read_track(directory / "work" / "cameras" / name / "track.csv")
        assert truth.on_target(track.frame, track.xy).mean() >= 0.95
        assert len(track) >= 20
        summary = timeline.cameras[name].identification
        assert summary.identified_frames == len(track)
        assert summary.support_frames > summary.runner_up_frames
        pictures = directory / "work" / "render"
        assert (pictures / f"movers_{name}.png").stat().st_size > 0 and (
            pictures / f"votes_movers_{name}.png"
        ).stat().st_size > 0
        assert movers.matching(track).sum() == len(track)  # the identified track is made of detected movers


def test_detections_brought_by_the_user_and_a_camera_without_the_path(two_walkers, tmp_path):
    """Cameras may bring their own detections.csv; one whose view the path never enters is named, the others
    synchronized (exit 1).
    """
    directory, _, _ = two_walkers
    parts = [f'[target]\ntrajectory = "{directory / "trajectory.csv"}"\n']
    for name in ("cam0", "cam1"):
        movers = read_detections(directory / "work" / "cameras" / name / "detections.csv")
        write_detections(movers, tmp_path / f"{name}_movers.csv")
        fps = json.loads((directory / f"{name}.json").read_text())["fps"]
        parts.append(
            f'[[cameras]]\nname = "{name}"\ncamera = "{directory / name}.json"\ndetections = "{name}_movers.csv"\nfps '
            f"= {fps}\n"
        )
    camera = json.loads((directory / "cam0.json").read_text())
    camera["t"] = [
        v - 1e4 if k == 2 else v for k, v in enumerate(camera["t"])
    ]  # the whole path 10 km behind this camera
    (tmp_path / "away.json").write_text(json.dumps(camera))
    away = read_detections(directory / "work" / "cameras" / "cam1" / "detections.csv")
    write_detections(
        dataclasses.replace(away, x=away.x + 0.5), tmp_path / "away_movers.csv"
    )  # its own file (one file for two cameras is bad input)
    parts.append('[[cameras]]\nname = "away"\ncamera = "away.json"\ndetections = "away_movers.csv"\nfps = 5.0\n')
    (tmp_path / "project.toml").write_text("\n".join(parts))
    result = _run("run", tmp_path / "project.toml", "--quiet")
    assert result.exit_code == 1, result.output
    timeline = read_timeline(tmp_path / "work" / "timeline.json")
    assert set(timeline.names) == {"cam0", "cam1"}
    assert "camera away: the target's projected path never enters its image" in timeline.failed["away"]
    assert max(_pair_errors(directory, timeline).values()) <= 0.5
    assert (tmp_path / "work" / "cameras" / "cam0" / "track.csv").exists()
    assert not (tmp_path / "work" / "cameras" / "away" / "track.csv").exists()


def _seeded_project(directory, tmp_path, box, init_frame):
    """A copy of a crowd project whose 5 fps camera has a blob tracker with an init box (its work folder copied too)."""
    copy = tmp_path / "seeded"
    shutil.copytree(directory, copy)
    text = (copy / "project.toml").read_text()
    head, tail = text.split('name = "cam1"\n', 1)
    table = f"\n[cameras.tracker]\ninit = [{', '.join(f'{v:.1f}' for v in box)}]\ninit_frame = {init_frame}\n"
    (copy / "project.toml").write_text(head + 'name = "cam1"\n' + tail.rstrip("\n") + "\n" + table)
    return copy


def test_an_init_box_seeds_the_identity_without_detecting_again(six_walkers, tmp_path):
    directory, crowd, _ = six_walkers
    truth = crowd.truth["cam1"]
    # The box is drawn, as a user would, in a frame where the target stands clear: one mover on it, of its size.
    movers = read_detections(directory / "work" / "cameras" / "cam1" / "detections.csv")
    on = truth.on_target(movers.frame, movers.xy)
    clear = (
        on
        & (np.abs(movers.h / (2 * truth.axes[movers.frame, 1]) - 1) < 0.2)
        & (np.abs(movers.w / (2 * truth.axes[movers.frame, 0]) - 1) < 0.4)
    )
    frame = int(movers.frame[np.flatnonzero(clear)[len(np.flatnonzero(clear)) // 2]])
    (x, y), (a, b) = truth.xy[frame], truth.axes[frame]
    copy = _seeded_project(directory, tmp_path, (x - a, y - b, 2 * a, 2 * b), frame)
    result = _run("run", copy / "project.toml", "--quiet", "--json")
    assert result.exit_code == 0, result.output
    states = {t["id"]: t["state"] for t in json.loads(result.output)["tasks"]}
    assert (
        states["track/cam1"] == "fresh" and states["identify/cam1"] == "ran"
    )  # the box seeds identify; detection is kept
    movers = read_detections(copy / "work" / "cameras" / "cam1" / "detections.csv")
    at_box = (movers.frame == frame) & truth.on_target(movers.frame, movers.xy)
    seeded_ids = set(movers.id[at_box].tolist())
    assert seeded_ids
    track = read_track(copy / "work" / "cameras" / "cam1" / "track.csv")
    timeline = read_timeline(copy / "work" / "timeline.json")
    assert {t.id for t in timeline.cameras["cam1"].identification.tracklets} & seeded_ids
    assert truth.on_target(track.frame, track.xy).mean() >= 0.95
    assert max(_pair_errors(copy, timeline).values()) <= 0.5


def test_a_blob_init_box_outside_the_image_is_bad_input(six_walkers, tmp_path):
    directory, _, _ = six_walkers
    copy = _seeded_project(directory, tmp_path, (470.0, 10.0, 40.0, 80.0), 3)
    result = _run("run", copy / "project.toml", "--quiet")
    assert result.exit_code == 2, result.output
    assert "init box [470, 10, 40, 80] is outside the image (480x360)" in result.output
