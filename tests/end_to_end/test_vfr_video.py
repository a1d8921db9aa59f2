"""Jittered presentation times through rendered videos.

First test: the video fixture jitters each time independently (no drift),
so times stay within 5 % of an interval of a constant rate and the
frame-index clock is kept (0.02-0.03 interval off).

Second test, the whole pipeline on phone-like videos: frame intervals
jittered by 10 % (the times drift: the presentation-time clock) and one
stream starting at pts 1.4 s. The frame map, the offsets and the frames
the pictures draw must follow the videos' own presentation times (measured:
median 0.002, max 0.005 frame off the truth; the linear ``pairs``
approximation is 0.6 median, 1.3 max).
"""

import csv
import json

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from calibration.camera import write_camera
from data_fixtures import make_scene
from data_fixtures.video import phone_times, render_video
from tlsync_pipeline.outputs.player import decode_times
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.trajectory import write_trajectory
from trackers.tracking import track_video

JITTER = 0.1  # the video fixture's jitter: uniform, as a fraction of the frame interval


def test_jittered_video_synchronized_in_seconds_within_one_frame(tmp_path):
    scene = make_scene(seed=0, n_frames=300, image_size=(320, 240))
    path = CubicSpline(scene.true_trajectory.sample, scene.true_trajectory.xyz, axis=0)
    inputs, times = {}, {}
    for name, camera in scene.true_cameras.items():
        n = scene.n_frames[name]
        line = scene.lines[name]
        kwargs = dict(
            n_frames=n,
            image_size=camera.image_size,
            fps=camera.fps,
            seed=1,
            occluder=False,
            distractor=False,
            jitter=JITTER,
        )
        # The fixture draws its times before it uses the positions: a first render gives them.
        times[name] = render_video(tmp_path / f"{name}-times.mp4", positions=np.full((n, 2), np.nan), **kwargs).times
        sample = (times[name] * camera.fps - line.beta) / line.alpha
        inside = (sample >= 0) & (sample <= scene.true_trajectory.sample[-1])
        uv, valid = camera.project(path(np.clip(sample, 0, None)))
        shown = inside & valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
        positions = np.where(shown[:, None], uv, np.nan)
        video = render_video(tmp_path / f"{name}.mp4", positions=positions, **kwargs)
        np.testing.assert_allclose(video.times, times[name])
        track = track_video(video.path, kind="blob", progress=False)
        np.testing.assert_allclose(track.time_s, times[name][track.frame], atol=2e-5)
        inputs[name] = CameraInput(scene.cameras[name], track, camera.fps)
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams())
    assert not timeline.failed
    for key, true in scene.truth_pairs().items():
        a, b = key.split("->")
        fa, fb = scene.cameras[a].fps, scene.cameras[b].fps
        t_a = times[a]
        estimated = timeline.seconds_relation(a, b)(t_a)
        truth = (true.alpha * t_a * fa + true.beta) / fb  # camera clocks: time x fps follows the lines
        error = np.mean(np.abs(estimated - truth)) * fb
        assert error < 1.0, key


PHONE_JITTER = 0.1  # each frame interval (1 + U(-0.1, 0.1)) / fps: times drift like a phone's
LATE_START_S = 1.4  # cam1's stream starts at this presentation time


def _truth_match(scene, times, start, a, b, frames_a):
    """True fractional frames of B at the instants of A's frames: camera clocks (time - start) x fps follow the scene's
    lines.
    """
    la, lb = scene.lines[a], scene.lines[b]
    fa, fb = scene.cameras[a].fps, scene.cameras[b].fps
    sample = ((times[a][frames_a] - start[a]) * fa - la.beta) / la.alpha
    time_b = (lb.alpha * sample + lb.beta) / fb + start[b]
    return np.interp(time_b, times[b], np.arange(len(times[b])), left=np.nan, right=np.nan)


def test_phone_videos_with_a_late_stream_map_frames_exactly(tmp_path):
    # Two phone-like cameras; cam1 starts 41 frames after cam0 and its stream's first pts is 1.4 s.
    scene = make_scene(seed=0, lines=((2.0, 45.61), (2.0, 4.37)), n_frames=300, image_size=(320, 240))
    path = CubicSpline(scene.true_trajectory.sample, scene.true_trajectory.xyz, axis=0)
    start = {"cam0": 0.0, "cam1": LATE_START_S}
    times, parts = {}, ['[target]\ntrajectory = "trajectory.csv"\n']
    write_trajectory(scene.trajectory, tmp_path / "trajectory.csv")
    for k, (name, camera) in enumerate(scene.true_cameras.items()):
        n, line = scene.n_frames[name], scene.lines[name]
        wanted = phone_times(n, camera.fps, PHONE_JITTER, start[name], seed=10 + k)
        sample = ((wanted - start[name]) * camera.fps - line.beta) / line.alpha
        inside = (sample >= 0) & (sample <= scene.true_trajectory.sample[-1])
        uv, valid = camera.project(path(np.clip(sample, 0, None)))
        shown = inside & valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
        video = render_video(
            tmp_path / f"{name}.mp4",
            n_frames=n,
            image_size=camera.image_size,
            fps=camera.fps,
            positions=np.where(shown[:, None], uv, np.nan),
            seed=k,
            occluder=False,
            distractor=False,
            times=wanted,
        )
        times[name] = video.times
        write_camera(scene.cameras[name], tmp_path / f"{name}.json")
        parts.append(
            f'[[cameras]]\nname = "{name}"\ncamera = "{name}.json"\nvideo = "{name}.mp4"\nfps = {camera.fps!r}\n'
        )
    (tmp_path / "project.toml").write_text("\n".join(parts), encoding="utf-8")
    summary = run_graph(build_graph(load_project(tmp_path / "project.toml"), tmp_path / "work"))
    assert not summary.failed, summary.failed
    timeline = json.loads((tmp_path / "work" / "timeline.json").read_text())
    assert all(timeline["cameras"][n]["clock"] == "time_s" for n in ("cam0", "cam1"))
    assert timeline["pairs"]["cam0->cam1"]["approximate"] is True

    # frame_map.csv: the matching frames, through each video's presentation times.
    with open(tmp_path / "work" / "exports" / "frame_map.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    mapped = {}
    for a, b in (("cam0", "cam1"), ("cam1", "cam0")):
        own = [r for r in rows if r["camera"] == a and r[f"frame_{b}"]]
        frames_a = np.array([int(r["frame"]) for r in own])
        estimated = np.array([float(r[f"frame_{b}"]) for r in own])
        truth = _truth_match(scene, times, start, a, b, frames_a)
        both = np.isfinite(truth)
        assert both.sum() > 200, (a, b)
        error = np.abs(estimated[both] - truth[both])
        assert np.median(error) < 0.1 and error.max() < 0.5, (a, b, np.median(error), error.max())
        mapped[a] = dict(zip(frames_a.tolist(), estimated))

    # offsets.csv: cam0's frame taken with cam1's frame 0, as in the frame map.
    with open(tmp_path / "work" / "exports" / "offsets.csv", newline="") as handle:
        offsets = {r["camera"]: r for r in csv.DictReader(handle)}
    assert float(offsets["cam1"]["start_frames"]) == pytest.approx(mapped["cam1"][0], abs=2e-3)
    true_start = _truth_match(scene, times, start, "cam1", "cam0", np.array([0]))[0]
    assert float(offsets["cam1"]["start_frames"]) == pytest.approx(true_start, abs=0.5)
    assert float(offsets["cam1"]["start_s"]) == pytest.approx(
        np.interp(true_start, np.arange(300), times["cam0"]) - times["cam0"][0], abs=0.5 / 30
    )

    # The pictures draw, with each frame of cam1, the frame of cam0 the frame map gives.
    drawn = summary.results["render"].facts["frames"]["cam0,cam1"]
    assert len(drawn) == 3
    for frame_b, frame_a in drawn:
        assert frame_a == round(mapped["cam1"][frame_b])

    # The player seeks each video through its own presentation times (the late start included).
    html = (tmp_path / "work" / "report.html").read_text(encoding="utf-8")
    player = json.loads(html.split('id="tlsync-player-data">', 1)[1].split("</script>", 1)[0])
    for entry in player["cameras"]:
        np.testing.assert_allclose(decode_times(entry["times"]), times[entry["name"]], atol=2e-6)
