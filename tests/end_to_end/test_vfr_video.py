"""Jittered presentation times through a rendered video: container times -> track -> seconds relation.

The video fixture jitters each time independently (no drift), so times stay
within 5 % of an interval of a constant rate and the frame-index clock is
kept (0.02-0.03 interval off); drifting times (the variable-frame-rate
clock) are tested at track level in test_refined.py.
"""

import numpy as np
from scipy.interpolate import CubicSpline

from data_fixtures import make_scene
from data_fixtures.video import render_video
from tlsync_pipeline.sync.params import SyncParams
from tlsync_pipeline.sync.synchronize import CameraInput, synchronize
from trackers.tracking import track_video

JITTER = 0.1  # the video fixture's jitter: uniform, as a fraction of the frame interval


def test_jittered_video_synchronized_in_seconds_within_one_frame(tmp_path):
    scene = make_scene(seed=0, n_frames=300, image_size=(320, 240))
    path = CubicSpline(scene.true_trajectory.sample, scene.true_trajectory.xyz, axis=0)
    inputs, times = {}, {}
    for name, camera in scene.true_cameras.items():
        n = scene.n_frames[name]
        line = scene.lines[name]
        kwargs = dict(n_frames=n, image_size=camera.image_size, fps=camera.fps, seed=1, occluder=False, distractor=False, jitter=JITTER)
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
