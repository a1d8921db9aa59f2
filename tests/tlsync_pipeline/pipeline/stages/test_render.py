"""Render: band-swap and strip pictures, plots, report, proxies, decoding only the frames drawn."""

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

from data_fixtures import make_scene, write_scene
from tlsync_pipeline.outputs import pictures as render
from tlsync_pipeline.outputs.calibration_report import calibration_summary, sync_pose_clause
from tlsync_pipeline.outputs.plots import track_residuals
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.render import drawn_as_fitted, fitted_radius
from tlsync_pipeline.sync.model.log_model import PRESETS
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import LinePose, LogCorrection, Relation
from tlsync_pipeline.sync.vote.log_error import gate_model, vote_radius
from tlsync_pipeline.trajectory import PiecewiseTrajectory


def _write_video(path, camera, track, n_frames):
    """A plain test video: grey noise with the target drawn as a white disc at its tracked position."""
    w, h = camera.image_size
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), camera.fps, (w, h))
    rng = np.random.default_rng(0)
    background = rng.integers(60, 120, (h, w, 3), dtype=np.uint8)
    where = dict(zip(track.frame.tolist(), track.xy))
    for f in range(n_frames):
        image = background.copy()
        if f in where:
            cv2.circle(image, tuple(int(round(c)) for c in where[f]), 5, (255, 255, 255), -1)
        writer.write(image)
    writer.release()


@pytest.fixture(scope="module")
def rendered_project(tmp_path_factory):
    scene = make_scene(seed=1, n_frames=400, image_size=(320, 240))
    folder = tmp_path_factory.mktemp("render")
    write_scene(scene, folder)
    toml = folder / "project.toml"
    for name, camera in scene.cameras.items():
        _write_video(folder / f"{name}.mp4", camera, scene.tracks[name], scene.n_frames[name])
        toml.write_text(
            toml.read_text().replace(
                f'track = "{name}/track.csv"', f'track = "{name}/track.csv"\nvideo = "{name}.mp4"\nproxy = "never"'
            )
        )
    return scene, folder


def _render(graph) -> list[str]:
    """Run the render stage alone (its inputs are made already); the pictures it wrote."""
    summary = run_graph(graph, force={"render"}, targets=["render"])
    assert summary.ran == ["render"], summary
    manifest = json.loads((graph.work / "render" / "render.manifest.json").read_text())
    return [rel.rsplit("/", 1)[-1] for rel in manifest["outputs"] if rel.endswith(".png")]


def test_render_decodes_only_the_frames_it_draws(rendered_project, monkeypatch):
    scene, folder = rendered_project
    project = load_project(folder / "project.toml")
    graph = build_graph(project, folder / "work")
    run_graph(graph, targets=["sync", "export"])
    requested = []
    original = render.read_frames

    def counting(path, indices):
        frames = original(path, indices)
        requested.append((path.name, sorted(frames)))
        return frames

    monkeypatch.setattr(render, "read_frames", counting)
    names = set(_render(graph))
    assert {
        "swap_cam0.png",
        "swap_cam1.png",
        "strip_cam0_cam1.png",
        "votes_cam0.png",
        "trajectory_cam1.png",
        "offsets.png",
        "residuals.png",
    } <= names
    assert (folder / "work" / "report.html").exists()
    decoded = {name: set() for name in ("cam0.mp4", "cam1.mp4")}
    for name, frames in requested:
        decoded[name] |= set(frames)
    # per camera three tracked frames for its band swap; for the strip three frames of cam1 and cam0's matches
    for name in ("cam0", "cam1"):
        assert len(decoded[f"{name}.mp4"]) <= 2 * render.FRAMES_PER_PAIR
    truth = scene.truth_pairs()["cam1->cam0"]
    matched = {int(round(float(truth(f)))) for f in decoded["cam1.mp4"] if 0 <= truth(f) < scene.n_frames["cam0"]}
    # the strip's three frames of cam1 have their matches decoded (its band swap's may have moved to keyframes)
    assert sum(min(abs(m - d) for d in decoded["cam0.mp4"]) <= 2 for m in matched) >= render.FRAMES_PER_PAIR
    strip = cv2.imread(str(folder / "work" / "render" / "strip_cam0_cam1.png"))
    assert strip.shape[0] >= render.FRAMES_PER_PAIR * render.PANEL_HEIGHT


def test_band_swap_after_synchronization_puts_the_rendered_target_on_the_real_one(rendered_project):
    """The test videos draw the target white at its tracked position: after = yellow overlap, before = apart."""
    scene, folder = rendered_project
    graph = build_graph(load_project(folder / "project.toml"), folder / "work")
    run_graph(graph, targets=["sync", "export"])
    _render(graph)
    swap = cv2.imread(str(folder / "work" / "render" / "swap_cam1.png"))
    half = swap.shape[1] // 2
    yellow = (swap[..., 2] > 200) & (swap[..., 1] > 200) & (swap[..., 0] < 50)  # not the white caption bars
    assert yellow[:, half:].sum() > 3 * 20  # three frames, each with the target's disc overlapping
    assert yellow[:, :half].sum() < yellow[:, half:].sum() / 4


def test_proxies_for_videos_the_browser_cannot_play(rendered_project):
    """The fixture's MPEG-4 part 2 videos get H.264 proxies with the same frames and times, linked from report.html."""
    from trackers.video import presentation_times, probe_video

    scene, folder = rendered_project
    toml = folder / "project.toml"
    policy = toml.read_text()
    try:
        toml.write_text(policy.replace('proxy = "never"', 'proxy = "auto"'))
        graph = build_graph(load_project(toml), folder / "work")
        run_graph(graph, targets=["sync", "export"])
        _render(graph)
        proxy = folder / "work" / "render" / "proxy" / "cam1.mp4"
        info = probe_video(proxy)
        assert info.codec == "h264" and info.height == 240
        np.testing.assert_allclose(presentation_times(proxy), presentation_times(folder / "cam1.mp4"), atol=1e-4)
        assert "render/proxy/cam1.mp4" in (folder / "work" / "report.html").read_text()
        before = proxy.stat().st_mtime_ns
        _render(graph)
        assert proxy.stat().st_mtime_ns == before  # the video did not change: the proxy is kept
    finally:
        toml.write_text(policy)


def test_choose_frames_stays_where_both_cameras_record():
    track = np.arange(100, 300)
    frames = render.choose_frames(track, Relation(1.0, -250.0), n_a=500, n_b=400)
    assert len(frames) == 3 and all(250 <= f < 300 for f in frames)
    assert render.choose_frames(track, Relation(1.0, 10_000.0), n_a=500, n_b=400) == []


def test_choose_frames_prefers_frames_that_decode_from_few_frames_on_both_sides():
    """Each pick moves (within the reach) to where B's frame and A's match are closest after their keyframes."""
    track = np.arange(100, 1100)
    to_a = Relation(1.0, 35.0)
    plain = render.choose_frames(track, to_a, n_a=2000, n_b=2000)
    keys_a, keys_b = np.arange(0, 2000, 60), np.arange(0, 2000, 60) + 20
    moved = render.choose_frames(track, to_a, n_a=2000, n_b=2000, keyframes=(keys_a, keys_b), reach=0.05)
    assert len(moved) == 3 and all(abs(m - p) <= 50 for m, p in zip(moved, plain))
    cost = render.run_up(np.round(to_a(np.array(moved))).astype(int), keys_a) + render.run_up(np.array(moved), keys_b)
    spent = render.run_up(np.round(to_a(np.array(plain))).astype(int), keys_a) + render.run_up(np.array(plain), keys_b)
    assert cost.tolist() == [5, 5, 5] and (cost < spent).all()  # B frame 5 after its keyframe, its match one of A
    only_b = render.choose_frames(track, to_a, n_a=2000, n_b=2000, keyframes=(None, keys_b), reach=0.05)
    assert all(f in keys_b for f in only_b)


@pytest.mark.slow
def test_pictures_asked_for_are_kept_beside_the_defaults_and_never_make_the_project_stale(
    rendered_project, monkeypatch
):
    """README's example: ``tlsync render project.toml --pair cam1,cam0 --frames 150,160``, then status and run."""
    from click.testing import CliRunner

    from tlsync_pipeline.cli.main import main

    scene, folder = rendered_project
    toml, render_dir = folder / "project.toml", folder / "work" / "render"

    def cli(*args):
        return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)

    assert cli("run", toml, "-j", "1", "-q").exit_code == 0
    defaults = {p.name: p.read_bytes() for p in render_dir.glob("*.png")}
    manifest = (render_dir / "render.manifest.json").read_text()
    requested = []
    original = render.read_frames
    monkeypatch.setattr(
        render,
        "read_frames",
        lambda path, indices: requested.append((path.name, sorted(indices))) or original(path, indices),
    )
    result = cli("render", toml, "--pair", "cam1,cam0", "--frames", "150,160", "-j", "1")
    assert result.exit_code == 0, result.output
    asked = render_dir / "pair_cam1_cam0_frames_150_160.png"
    assert asked.stat().st_size > 1000 and "wrote " in result.output
    assert sorted(name for name, _ in requested) == ["cam0.mp4", "cam1.mp4"]  # only the strip's frames, each video once
    assert {150, 160} == set(dict(requested)["cam0.mp4"])
    assert {
        p.name: p.read_bytes() for p in render_dir.glob("*.png") if p != asked
    } == defaults  # the defaults untouched
    assert (render_dir / "render.manifest.json").read_text() == manifest
    assert cli("status", toml, "-q").exit_code == 0  # still fresh
    assert "ran 0," in cli("run", toml, "-j", "1").output and asked.exists()
    before = asked.stat().st_mtime_ns
    assert cli("run", toml, "-j", "1", "-q", "--force", "render").exit_code == 0
    assert asked.exists() and asked.stat().st_mtime_ns > before  # drawn again with the other pictures
    assert cli("status", toml, "-q").exit_code == 0
    bad = cli("render", toml, "--pair", "cam1,cam7")
    assert (
        bad.exit_code == 2
        and bad.output.startswith("error: ")
        and "no camera named 'cam7'" in bad.output
        and len(bad.output.splitlines()) == 1
    ), bad.output
    late = cli("render", toml, "--pair", "cam1,cam0", "--frames", "99999")
    assert late.exit_code == 2 and "frame 99999 is not a frame of cam0" in late.output, late.output


def test_render_never_decodes_the_videos_through(rendered_project, monkeypatch):
    """Decoding starts at the keyframe before each drawn frame: a few GOPs, not whole videos."""
    from collections import Counter

    from trackers import video

    scene, folder = rendered_project
    graph = build_graph(load_project(folder / "project.toml"), folder / "work")
    run_graph(graph, targets=["sync", "export"])
    decoded = Counter()
    original = video._decode

    def counting(container, stream, needed=None, drain_after=None):
        for frame, error in original(container, stream, needed, drain_after):
            decoded[container.name.rsplit("/", 1)[-1]] += 1
            yield frame, error

    monkeypatch.setattr(video, "_decode", counting)
    _render(graph)
    assert decoded["cam1.mp4"] > 0 and decoded["cam0.mp4"] > 0
    for name in ("cam0", "cam1"):
        assert decoded[f"{name}.mp4"] < scene.n_frames[name] / 3, decoded


def test_pictures_prefer_tracked_keyframes_nearby():
    """A keyframe decodes alone: a band swap's or the movers picture's frame moves to a tracked keyframe close by, if
    any.
    """
    from tlsync_pipeline.outputs.camera_pictures import band_swap_frames
    from trackers.detections import make_detections
    from trackers.track import Track

    frames = np.arange(100, 1100)
    track = Track(frames, np.zeros(len(frames)), np.zeros(len(frames)))
    keyframes = np.arange(0, 2000, 60)
    assert band_swap_frames(track) == [300, 600, 899]
    assert band_swap_frames(track, keyframes) == [300, 600, 900]  # 300, 600 and 900 are keyframes
    assert band_swap_frames(track, keyframes + 20) == [320, 620, 920]
    assert render.toward_keyframes([300], frames, np.array([400]), reach=50) == [300]  # too far: kept
    movers = make_detections(
        [(f, f / 30, 0, 1.0, 1.0, 5, 5, 1.0) for f in (150, 150, 150, 180)] + [(180, 6.0, 1, 2.0, 2.0, 5, 5, 1.0)]
    )
    assert render.choose_movers_frame(movers, track) == 150
    assert render.choose_movers_frame(movers, track, keyframes) == 180  # the keyframe with most movers


def test_with_the_runs_workers_started_the_charts_are_drawn_there_and_come_out_the_same(rendered_project, monkeypatch):
    """Render hands the charts to the run's workers beside the cameras' pictures (this process loads no matplotlib
    for them): the same PNG bytes as drawn here."""
    import os

    from tlsync_pipeline.pipeline.executors import ProcessExecutor
    from tlsync_pipeline.pipeline.stages import render as render_stage

    _, folder = rendered_project
    graph = build_graph(load_project(folder / "project.toml"), folder / "work")
    run_graph(graph, targets=["sync", "export"])
    _render(graph)  # no worker started: every part drawn here
    charts = {name: (folder / "work" / "render" / name).read_bytes() for name in ("offsets.png", "residuals.png")}

    def not_here(*args, **kwargs):
        raise AssertionError("a chart drawn in the run's own process")

    monkeypatch.setattr(render_stage, "offsets_plot", not_here)
    monkeypatch.setattr(render_stage, "residuals_plot", not_here)
    executor = ProcessExecutor(2)
    executor.submit(os.getpid, {}).result()  # a task started the workers
    summary = run_graph(graph, executor, force={"render"}, targets=["render"])
    assert summary.ran == ["render"] and not summary.failed, summary
    assert {name: (folder / "work" / "render" / name).read_bytes() for name in charts} == charts


def test_the_pictures_are_drawn_with_the_pose_and_log_the_lines_were_fitted_with():
    """A line that carries a pose (the sync found it: timeline.json's cameras.<name>.pose) is drawn with it, on the log
    corrected as the sync corrected it; camera.json's pose and the log as given otherwise."""
    scene = make_scene(seed=1)
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams())
    as_given = {**inputs, "cam1": replace(inputs["cam1"], camera=inputs["cam1"].camera.without_pose())}
    drawn, log = drawn_as_fitted(timeline, as_given, scene.trajectory)
    assert all(drawn[n] is as_given[n] for n in as_given) and log is scene.trajectory

    found = LinePose.of(scene.cameras["cam1"], "second_pass")
    correction = LogCorrection(scene.trajectory.sample[[0, -1]], np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    lines = {**timeline.cameras, "cam1": replace(timeline.cameras["cam1"], pose=found)}
    fitted = replace(timeline, cameras=lines, log_correction=correction)
    drawn, log = drawn_as_fitted(fitted, as_given, scene.trajectory)
    assert drawn["cam0"] is as_given["cam0"] and drawn["cam1"].camera.posed
    points = scene.trajectory.xyz[:20]
    np.testing.assert_allclose(drawn["cam1"].camera.project(points)[0], scene.cameras["cam1"].project(points)[0])
    np.testing.assert_allclose(log.xyz - scene.trajectory.xyz, np.tile([1.0, 0.0, 0.0], (len(log), 1)))

    # A log off the truth by a bias, the lines' poses fitted on it corrected (a kept refit's, "bias_refit"): both the
    # camera posed by the sync and the surveyed one are drawn on the track (noise-free: within a thousandth of a
    # pixel), where the log as given would put them tens of pixels off.
    bias = np.array([2.0, -1.0, 0.5])
    logged = replace(scene.trajectory, xyz=scene.trajectory.xyz - bias)
    refitted_on = LogCorrection(scene.trajectory.sample[[0, -1]], np.tile(bias, (2, 1)), "bias_refit")
    lines = {**timeline.cameras, "cam1": replace(timeline.cameras["cam1"], pose=replace(found, source="bias_refit"))}
    drawn, log = drawn_as_fitted(replace(timeline, cameras=lines, log_correction=refitted_on), as_given, logged)
    for name, line in lines.items():
        on_track = _median_off(drawn[name].camera, scene.tracks[name], log, line)
        as_logged = _median_off(drawn[name].camera, scene.tracks[name], logged, line)
        assert on_track < 0.01 and as_logged > 10.0, (name, on_track, as_logged)


def _median_off(camera, track, log, line) -> float:
    """Median distance (pixels) of the track from the log projected at the line's samples, as the pictures draw it
    (the prepared log's path model)."""
    path = PiecewiseTrajectory(prepare_trajectory(log, preparation_of(SyncParams())))
    return float(np.median(track_residuals(camera, track, path, line).distance))


def test_the_calibration_line_says_when_the_line_was_fitted_with_the_syncs_pose():
    camera = make_scene(seed=1).cameras["cam0"]
    report = {"target_pose": {"camera_center_m": (camera.center + np.array([3.0, 4.0, 0.0])).tolist()}}
    text = sync_pose_clause("second_pass+bias_refit", camera.center, report)
    assert "searched again on the log corrected for its bias, then refitted under the log's bias" in text
    assert "its centre 5.00 m from this one" in text and "draw that pose" in text
    assert "centre" not in sync_pose_clause("target", camera.center, {"target_pose": {"error": "no pose"}})


def test_a_camera_the_calibrate_stage_could_not_pose_is_not_said_unsynchronized_before_the_sync():
    """The sync's later passes may pose and synchronize it: the calibrate stage's line names the cause only."""
    report = {"camera": "cam1", "intrinsics": {"source": "camera.json"}}
    report["target_pose"] = {"error": "no pose", "cause": "not_upright"}
    text = calibration_summary(report)
    assert "no pose from the target (not_upright; under a log with a bias the sync searches it again" in text
    assert "not synchronized" not in text


def test_the_voting_space_is_cast_again_at_the_radius_the_sync_gave_the_camera():
    """Without a log error model the radius is eps_px; with one, the radius its gate model gives the camera (a
    phone's metres of error: wider than eps_px), as the sync's votes had it."""
    scene = make_scene(seed=1)
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    prepared = prepare_trajectory(scene.trajectory, preparation_of(SyncParams()))
    camera = scene.cameras["cam0"]
    plain, _ = synchronize(inputs, scene.trajectory, SyncParams())
    assert fitted_radius(plain, camera, prepared) == SyncParams().eps_px
    phone, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["phone"])
    gate = gate_model(PRESETS["phone"], scene.trajectory)
    radius = fitted_radius(phone, camera, prepared)
    assert radius == pytest.approx(vote_radius(camera, prepared, SyncParams().eps_px, gate)) and radius > 20.0
