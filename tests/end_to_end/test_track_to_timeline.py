"""End to end from pixels: rendered camera videos -> blob tracks -> synchronization against the truth."""

import numpy as np

from data_fixtures import make_scene
from data_fixtures.video import render_camera_video
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import eps_t
from trackers.tracking import track_video


def test_tracks_from_rendered_videos_synchronize_the_scene(tmp_path):
    scene = make_scene(seed=0, n_frames=300, image_size=(320, 240))
    inputs = {}
    for name, camera in scene.true_cameras.items():
        truth = scene.tracks[name]  # noise-free projections of the trajectory, frames where in view
        positions = [None] * scene.n_frames[name]
        for f, x, y in zip(truth.frame, truth.x, truth.y):
            positions[f] = (x, y)
        video = render_camera_video(camera, positions, fps=camera.fps, path=tmp_path / f"{name}.mp4", seed=1)
        track = track_video(video.path, kind="blob", progress=False)
        inside = video.in_view[track.frame]
        error = np.hypot(track.x - video.truth[track.frame, 0], track.y - video.truth[track.frame, 1])
        assert inside.sum() > 50 and np.median(error[inside]) < 1.0
        np.testing.assert_allclose(track.time_s, track.frame / camera.fps, atol=1e-3)
        inputs[name] = CameraInput(scene.cameras[name], track, camera.fps)
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams())
    assert not timeline.failed
    for key, true in scene.truth_pairs().items():
        a = key.split("->")[0]
        assert eps_t(timeline.relation(*key.split("->")), true, scene.n_frames[a]) < 0.5, key
