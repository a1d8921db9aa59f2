"""The causes a contradicted camera's track is tested for (sync/solve/causes.py), on the quick demo scene's cameras."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from data_fixtures import make_scene
from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.walk import WalkSpec, make_walk_scene
from tlsync_pipeline.sync.kernels.smoothing import smooth_trajectory
from tlsync_pipeline.sync.model.log_model import PRESETS, LogModel
from tlsync_pipeline.sync.solve.causes import explain, image_offset
from tlsync_pipeline.sync.solve.plausibility import GATE_EPS, Judged, LogUnitError
from tlsync_pipeline.sync.vote.log_error import vote_radius
from tlsync_pipeline.trajectory import PiecewiseTrajectory

EPS_PX = 10.0


@pytest.fixture(scope="module")
def scene():
    return make_scene(0, lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)), n_frames=(512, 512, 300), tracking_noise_px=1.0)


def _judged(scene, contradicted, shift=(0.0, 0.0)):
    out = {}
    for name, camera in scene.cameras.items():
        track = scene.tracks[name]
        if name in contradicted:
            track = replace(track, x=track.x + shift[0], y=track.y + shift[1])
        out[name] = Judged(camera, track, None, None, name in contradicted)
    return out


def test_a_constant_pixel_offset_is_found_and_named(scene):
    judged = _judged(scene, {"cam1"}, (0.0, 60.0))
    offset = image_offset(
        judged["cam1"].camera, judged["cam1"].track.xy, PiecewiseTrajectory(scene.trajectory), GATE_EPS * EPS_PX
    )
    assert offset is not None and abs(offset[0]) < 10 and 40 < offset[1] <= 62
    reasons = explain(judged, scene.trajectory, EPS_PX)
    assert list(reasons) == ["cam1"] and reasons["cam1"].code == "track_offset" and "shadow" in reasons["cam1"].remedy


def test_a_log_riding_above_is_named_with_the_key_and_its_value(scene):
    raised = replace(scene.trajectory, xyz=scene.trajectory.xyz + [0.0, 0.0, 1.5])
    reasons = explain(_judged(scene, {"cam2"}), raised, EPS_PX, above_m=0.2)
    assert reasons["cam2"].code == "log_height" and "logged_point_above_m = 1.7" in reasons["cam2"].remedy
    with pytest.raises(LogUnitError, match=r"column z: heights 4\d(\.\d)? m too high: .*altitude_reference"):
        explain(
            _judged(scene, set(scene.cameras)),
            replace(scene.trajectory, xyz=scene.trajectory.xyz + [0.0, 0.0, 47.0]),
            EPS_PX,
        )


def test_right_cameras_and_tracks_on_the_path_get_no_cause(scene):
    assert explain(_judged(scene, set()), scene.trajectory, EPS_PX) == {}
    assert explain(_judged(scene, {"cam0"}), scene.trajectory, EPS_PX) == {}  # on the path: its timing is at fault


def test_a_log_wandering_by_metres_beyond_its_model_is_named_not_the_tracker():
    """A phone's 2 m / 60 s log whose fixes scatter by 0.5 m, checked at the exact log's gate (2 eps_px): the tracks
    lie off the projected path there, but on it within a phone's radius. The cause is the log's error (declare it),
    not a tracker on another object (track_elsewhere); a log whose fixes do not scatter gets no such cause."""
    walk = make_walk_scene(3, WalkSpec(route="turns", log=RECEIVERS["phone2"], lead_s=30.0))
    judged = {n: Judged(c, walk.tracks[n], None, None, True) for n, c in walk.cameras.items()}
    reasons = explain(judged, walk.trajectory, EPS_PX, log_model=LogModel("custom", 0.5))
    assert set(reasons) == set(walk.cameras) and {r.code for r in reasons.values()} == {"log_error"}, reasons
    assert all('log_model = "phone"' in r.remedy for r in reasons.values())
    exact = explain(judged, walk.trajectory, EPS_PX, log_model=PRESETS["none"])
    assert "log_error" not in {r.code for r in exact.values()}
    as_phone = {n: vote_radius(c, walk.trajectory, EPS_PX, PRESETS["phone"]) for n, c in walk.cameras.items()}
    assert explain(judged, walk.trajectory, EPS_PX, radius_px=as_phone, log_model=PRESETS["phone"]) == {}  # on it


def test_a_biased_log_projected_beside_a_view_is_named_the_logs_error_not_the_tracker():
    """A walk along a view's edge logged by a phone (2 m / 60 s) whose bias puts every fix just outside the image: the
    log's error seen at the depth of the fixes beside the image spans the track (the vote radius is a phone's, not
    eps_px); under a model that gives it eps_px the cause is the log's error (log_error, its key), not a tracker on
    another object."""
    walk = make_walk_scene(16, WalkSpec(route="turns", log=RECEIVERS["phone2"]))
    camera, smoothed = walk.cameras["cam1"], smooth_trajectory(walk.trajectory)  # the refined method's log
    uv, valid = camera.project(smoothed.xyz)
    assert not (valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))).any()  # every fix beside the image
    assert vote_radius(camera, smoothed, EPS_PX, PRESETS["phone"]) > 30 * EPS_PX
    judged = {"cam1": Judged(camera, walk.tracks["cam1"], None, None, True)}
    reasons = explain(judged, smoothed, EPS_PX, radius_px={"cam1": EPS_PX}, log_model=PRESETS["phone"])
    assert reasons["cam1"].code == "log_error" and "log_model" in reasons["cam1"].remedy, reasons
