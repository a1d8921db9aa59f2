"""The coarse pass's line and the fine pass's windows, on keyframe movers with known truth (no video)."""

import dataclasses

import numpy as np
import pytest

from data_fixtures import make_scene
from tlsync_pipeline.sync.identify.identify import identify_params
from tlsync_pipeline.sync.identify.scan import (
    MIN_KEYFRAMES,
    OffsetPrior,
    ScanPlan,
    before_coarse,
    coarse_stride,
    keyframe_range,
    plan_scan,
)
from tlsync_pipeline.sync.model.params import SyncParams
from trackers.detections import make_detections

P = identify_params(SyncParams())
GOP = 30


@pytest.fixture(scope="module")
def long_scene():
    """Two cameras recording 6 minutes at 30 and 25 fps at the same time; the target stays 40 s in each view."""
    return make_scene(
        0, ((3.0, -300.0), (2.5, 500.0)), (10800, 9000), target_rate=10.0, image_size=(640, 360), window_samples=400
    )


def _keyframe_movers(scene, name, walkers=6, seed=0, extra=(), shown=None):
    """Every mover of the keyframes (one every GOP frames): the target where it is in view (0.7 px noise, 10 % missed;
    on its first ``shown`` keyframes only, if given), ``walkers`` look-alikes anywhere in the image on every keyframe,
    and ``extra`` (frame, x, y) rows."""
    rng = np.random.default_rng(seed)
    n = scene.n_frames[name]
    keys = np.arange(0, n, GOP)
    track = scene.tracks[name]
    w, h = scene.cameras[name].image_size
    rows = []
    on_key = np.isin(track.frame, keys) & (rng.random(len(track)) > 0.1)
    if shown is not None:
        on_key[np.flatnonzero(on_key)[shown:]] = False
    for f, (x, y) in zip(track.frame[on_key], track.xy[on_key] + rng.normal(0, 0.7, (on_key.sum(), 2))):
        rows.append((f, x, y))
    for f in keys:
        for x, y in rng.uniform([0, 0], [w, h], (walkers, 2)):
            rows.append((f, x, y))
    rows += list(extra)
    fps = scene.cameras[name].fps
    return make_detections([(f, f / fps, k, x, y, 10, 10, 1.0) for k, (f, x, y) in enumerate(rows)]), keys


def _plan(scene, name, movers, keys, **kwargs):
    camera = scene.cameras[name]
    return plan_scan(
        camera, movers, scene.trajectory, camera.fps, kwargs.pop("params", P), keys, scene.n_frames[name], **kwargs
    )


@pytest.mark.parametrize("name", ["cam0", "cam1"])
def test_windows_hold_every_frame_of_the_target_and_little_else(long_scene, name):
    movers, keys = _keyframe_movers(long_scene, name)
    plan = _plan(long_scene, name, movers, keys)
    assert not plan.full, plan.reason
    truth = long_scene.lines[name]
    assert abs(plan.coarse.beta - truth.beta) < 2 * truth.alpha  # within two log samples
    assert plan.coarse.support >= 10 and plan.coarse.runner_up < plan.coarse.support / 2
    inside = np.zeros(long_scene.n_frames[name], bool)
    for a, b in plan.windows:
        assert a in keys  # each window starts at a keyframe
        inside[a:b] = True
    track = long_scene.tracks[name]
    assert inside[track.frame].all()
    assert plan.frames_in_windows < 1.6 * len(track)  # about 12 % of the video for the target's 11 %
    again = ScanPlan.from_dict(plan.to_dict())
    assert again == plan
    assert "skipped" in plan.summary()


def test_a_look_alike_on_the_path_at_another_time_makes_it_ambiguous(long_scene):
    """A second mover that follows the target's projected path 90 s later: two lines equally strong, every frame is
    read.
    """
    name = "cam0"
    track = long_scene.tracks[name]
    shift = 90 * 30
    echo = [
        (f + shift, x, y)
        for f, (x, y) in zip(track.frame, track.xy)
        if (f + shift) % GOP == 0 and f + shift < long_scene.n_frames[name]
    ]
    movers, keys = _keyframe_movers(long_scene, name, extra=echo)
    plan = _plan(long_scene, name, movers, keys)
    assert plan.full and "ambiguous" in plan.reason
    assert plan.windows == ((0, long_scene.n_frames[name]),)


def test_keyframes_read_about_so_many_seconds_apart():
    assert coarse_stride(np.arange(0, 9000, 60), 9000, 50.0, 2.0) == 2  # every 1.2 s: every other one, 2.4 s apart
    assert coarse_stride(np.arange(0, 9000, 60), 9000, 50.0, 4.0) == 3
    assert coarse_stride(np.arange(0, 9000, 60), 9000, 25.0, 4.0) == 2  # every 2.4 s: 4.8 s apart
    assert coarse_stride(np.arange(0, 9000, 15), 9000, 30.0, 2.0) == 4
    assert coarse_stride(np.arange(0, 9000, 60), 9000, 30.0, 4.0) == 2
    assert coarse_stride(np.arange(0, 9000, 15), 9000, None, 4.0) == 1


def test_every_other_keyframe_finds_the_line(long_scene):
    name = "cam0"
    movers, keys = _keyframe_movers(long_scene, name)
    every_other = movers.subset(np.isin(movers.frame, keys[::2]))
    plan = _plan(long_scene, name, every_other, keys, read=keys[::2])
    assert not plan.full and plan.keyframes_read == len(keys[::2])
    assert all(a in keys for a, _ in plan.windows)  # windows start at any keyframe, read or not
    inside = np.zeros(long_scene.n_frames[name], bool)
    for a, b in plan.windows:
        inside[a:b] = True
    assert inside[long_scene.tracks[name].frame].all()


def test_too_few_keyframes_show_the_target(long_scene):
    name = "cam1"
    movers, keys = _keyframe_movers(long_scene, name, shown=MIN_KEYFRAMES - 2)
    plan = _plan(long_scene, name, movers, keys)
    assert plan.full and ("keyframes show the target" in plan.reason or "ambiguous" in plan.reason), plan.reason


def test_no_slope_prior_reads_every_frame(long_scene):
    name = "cam0"
    movers, keys = _keyframe_movers(long_scene, name)
    camera = long_scene.cameras[name]
    free = dataclasses.replace(P, rate_sigma=0.0)
    assert "slope prior" in before_coarse(
        camera, long_scene.trajectory, long_scene.n_frames[name], keys, camera.fps, free
    )
    assert "slope prior" in _plan(long_scene, name, movers, keys, params=free).reason


def test_reasons_before_decoding(long_scene):
    name = "cam0"
    camera, n = long_scene.cameras[name], long_scene.n_frames[name]
    assert before_coarse(camera, long_scene.trajectory, n, np.arange(0, n, GOP), camera.fps, P) is None
    assert "packet index" in before_coarse(camera, long_scene.trajectory, None, None, camera.fps, P)
    assert "cost about as much" in before_coarse(camera, long_scene.trajectory, n, np.arange(0, n, 2), camera.fps, P)
    alone = make_scene(
        0, ((3.0, -30.0),), 900, target_rate=10.0, image_size=(640, 360)
    )  # the target in view most of the video
    assert "in view" in before_coarse(alone.cameras["cam0"], alone.trajectory, 900, np.arange(0, 900, GOP), 30.0, P)


def test_an_offset_prior_narrows_the_keyframes_read(long_scene):
    name = "cam1"
    truth = long_scene.lines[name]
    n = long_scene.n_frames[name]
    lo, hi = keyframe_range(long_scene.trajectory, truth.alpha, OffsetPrior(truth.beta + 40, 150.0), n, 60)
    span = truth.alpha * np.ptp(long_scene.trajectory.sample)
    assert hi - lo == pytest.approx(span + 2 * 150 + 2 * 60, abs=3)
    assert keyframe_range(long_scene.trajectory, truth.alpha, None, n, 60) == (0, n)
    movers, keys = _keyframe_movers(long_scene, name)
    kept = movers.subset((movers.frame >= lo) & (movers.frame < hi))
    plan = _plan(long_scene, name, kept, keys[(keys >= lo) & (keys < hi)], prior=OffsetPrior(truth.beta + 40, 150.0))
    assert not plan.full and abs(plan.coarse.beta - truth.beta) < 2 * truth.alpha


def test_the_keyframes_between_are_read_when_the_first_ones_cannot_decide(long_scene, monkeypatch):
    """Keyframes 4 s apart first; the target shows only on those between them: the 2 s ones are read and decide."""
    from tlsync_pipeline.pipeline.stages import scan as stage

    name = "cam0"
    movers, keys = _keyframe_movers(long_scene, name, walkers=3)
    track = np.isin(movers.frame, long_scene.tracks[name].frame) & (movers.id < 1000)
    hidden = track & (movers.frame % (4 * GOP) == 0)  # not on the 4 s keyframes
    movers = movers.subset(~hidden)
    calls = []

    def detect(video, indices, first_id, detector, meter=None, decoded=None):
        calls.append(list(indices))
        rows = movers.subset(np.isin(movers.frame, indices))
        return dataclasses.replace(rows, id=np.arange(first_id, first_id + len(rows)))

    monkeypatch.setattr(stage, "detect_keyframe_movers", detect)
    monkeypatch.setattr(stage, "movers_detector", lambda video, parameters, background=None: None)
    monkeypatch.setattr(stage, "frame_count", lambda video: long_scene.n_frames[name])
    monkeypatch.setattr(stage, "keyframe_indices", lambda video: keys)
    monkeypatch.setattr(stage, "presentation_times", lambda video: None)
    monkeypatch.setattr(stage, "packet_sizes", lambda video: None)
    camera = long_scene.cameras[name]
    plan = stage.scan_video("v.mp4", camera, long_scene.trajectory, camera.fps, P)
    assert calls[0] == keys[::4].tolist() and calls[1] == np.setdiff1d(keys[::2], keys[::4]).tolist()
    assert not plan.full and plan.keyframes_read == len(keys[::2])


def test_a_camera_clock_prior_reads_only_the_keyframes_near_the_log(long_scene, monkeypatch):
    """With an offset prior, the keyframes read are those where the log can be seen (its span, the
    tolerance, a margin).
    """
    from tlsync_pipeline.pipeline.stages import scan as stage

    name = "cam1"
    movers, keys = _keyframe_movers(long_scene, name)
    calls = []

    def detect(video, indices, first_id, detector, meter=None, decoded=None):
        calls.extend(indices)
        rows = movers.subset(np.isin(movers.frame, indices))
        return dataclasses.replace(rows, id=np.arange(first_id, first_id + len(rows)))

    monkeypatch.setattr(stage, "detect_keyframe_movers", detect)
    monkeypatch.setattr(stage, "movers_detector", lambda video, parameters, background=None: None)
    monkeypatch.setattr(stage, "frame_count", lambda video: long_scene.n_frames[name])
    monkeypatch.setattr(stage, "keyframe_indices", lambda video: keys)
    monkeypatch.setattr(stage, "presentation_times", lambda video: None)
    monkeypatch.setattr(stage, "packet_sizes", lambda video: None)
    camera, truth = long_scene.cameras[name], long_scene.lines[name]
    prior = OffsetPrior(truth.beta + 40, 150.0)
    plan = stage.scan_video("v.mp4", camera, long_scene.trajectory, camera.fps, P, prior=prior)
    lo, hi = keyframe_range(long_scene.trajectory, truth.alpha, prior, long_scene.n_frames[name], 0.5 * camera.fps + 1)
    assert calls and min(calls) >= lo and max(calls) < hi
    assert (keys < lo).sum() + (keys >= hi).sum() >= 10  # keyframes the prior kept from being read
    assert not plan.full and abs(plan.coarse.beta - truth.beta) < 2 * truth.alpha
