"""A flight slowed down and hovering: the log and the tracks follow one warp of time, and the truth with them."""

from __future__ import annotations

import numpy as np

from calibration.camera import Camera
from data_fixtures.slowed_flight import cropped, slow_part, slowed_flight, speed_cap_warp, time_warp
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.timeline import Relation
from tlsync_pipeline.trajectory import Trajectory
from trackers.track import Track

RATE = 5.0  # fixes per second
SPEED = 3.0  # metres per second along x


def flight(gap: slice | None = None) -> tuple[dict[str, CameraInput], Trajectory, dict[str, Relation], dict]:
    """A target flying along x; one camera whose track's x is the target's x at its frame (clock = 6 sample - 30)."""
    sample = np.arange(0.0, 400.0)
    log = Trajectory(sample, np.column_stack([SPEED * sample / RATE, np.zeros((400, 2))]), RATE)
    line = Relation(6.0, -30.0)
    frames = np.arange(0, 1200)
    keep = np.ones(len(frames), dtype=bool)
    if gap is not None:
        keep[gap] = False
    x = SPEED * (frames - line.beta) / line.alpha / RATE
    track = Track(frames[keep], x[keep], np.zeros(keep.sum()))
    camera = Camera(name="cam", K=np.eye(3), dist=np.zeros(5), R=np.eye(3), t=np.zeros(3), image_size=(100, 100))
    return {"cam": CameraInput(camera, track, 30.0)}, log, {"cam": line}, {"cam": 1200}


def test_no_warp_keeps_the_flight():
    cameras, log, lines, n_frames = flight(gap=slice(500, 540))
    out = slowed_flight(cameras, log, lines, n_frames, time_warp(79.8, 1.0))
    assert np.array_equal(out.cameras["cam"].track.frame, cameras["cam"].track.frame)
    assert np.allclose(out.cameras["cam"].track.x, cameras["cam"].track.x)
    assert np.allclose(out.trajectory.xyz, log.xyz)
    assert out.lines["cam"] == lines["cam"] and out.n_frames == n_frames


def test_slowed_and_hovering_track_shows_the_log_at_its_true_line():
    cameras, log, lines, n_frames = flight(gap=slice(500, 540))
    warp = time_warp(79.8, 3.0, hover_s=10.0, hover_every_s=20.0)
    out = slowed_flight(cameras, log, lines, n_frames, warp)
    track, line = out.cameras["cam"].track, out.lines["cam"]
    assert line.alpha == lines["cam"].alpha
    assert out.n_frames["cam"] > 3 * n_frames["cam"]
    sample = (track.frame - line.beta) / line.alpha  # the new log's sample at each new frame, by the new true line
    seen = np.interp(sample, out.trajectory.sample, out.trajectory.xyz[:, 0])
    inside = (sample >= 0) & (sample <= out.trajectory.sample[-1])
    assert inside.sum() > 3000
    assert np.abs(track.x[inside] - seen[inside]).max() < 1e-6
    speed = np.linalg.norm(np.diff(out.trajectory.xyz, axis=0), axis=1) * RATE
    assert np.isclose(np.median(speed[speed > 0]), SPEED / 3.0)
    assert (speed == 0).sum() >= 3 * 10 * RATE - 3  # three hovers of 10 s


def test_pairs_follow_the_lines():
    cameras, log, lines, n_frames = flight()
    other = Camera(name="b", K=np.eye(3), dist=np.zeros(5), R=np.eye(3), t=np.zeros(3), image_size=(100, 100))
    cameras["b"] = CameraInput(other, cameras["cam"].track, 25.0)
    lines["b"] = Relation(5.0, 100.0)
    n_frames["b"] = 1200
    out = slowed_flight(cameras, log, lines, n_frames, time_warp(79.8, 2.0))
    pair = out.pairs()["cam->b"]
    frame = np.array([0.0, 777.0])
    sample = (frame - out.lines["cam"].beta) / out.lines["cam"].alpha
    assert np.allclose(pair.alpha * frame + pair.beta, out.lines["b"].alpha * sample + out.lines["b"].beta)


def test_slow_part_keeps_the_hovers_only():
    cameras, log, lines, n_frames = flight()
    hovering = slowed_flight(cameras, log, lines, n_frames, time_warp(79.8, 1.0, 10.0, 20.0))
    out = slow_part(hovering, 0.5)
    track, line = out.cameras["cam"].track, out.lines["cam"]
    seconds = (track.frame - line.beta) / line.alpha / RATE
    starts = (20.0, 50.0, 80.0)  # the hovers at 20, 40 and 60 s of the flight, each after the ones before
    assert all(any(lo <= s <= lo + 10.0 for lo in starts) for s in seconds)
    assert len(track) > 0.9 * 2 * 10.0 * 30.0  # nearly every frame of the two hovers the video spans (30 fps)
    assert len(track) < 0.5 * len(hovering.cameras["cam"].track)


def test_speed_cap_stretches_only_the_fast_parts():
    cameras, log, lines, n_frames = flight()
    xyz = log.xyz.copy()
    xyz[200:, 0] = xyz[200, 0]  # the target hovers from the 40th second
    hovering = Trajectory(log.sample, xyz, RATE)
    track, line = cameras["cam"].track, lines["cam"]
    seen = np.interp((track.frame - line.beta) / line.alpha, log.sample, xyz[:, 0])
    cameras["cam"] = CameraInput(cameras["cam"].camera, Track(track.frame, seen, track.y), 30.0)
    out = slowed_flight(cameras, hovering, lines, n_frames, speed_cap_warp(log.sample / RATE, xyz, 1.0))
    speed = np.linalg.norm(np.diff(out.trajectory.xyz, axis=0), axis=1) * RATE
    moving = speed > 0
    assert np.allclose(speed[moving][1:-1], 1.0)  # 3 m/s flown at 1 m/s
    assert (~moving).sum() >= 200 - 2  # the hover keeps its 40 s
    track, line = out.cameras["cam"].track, out.lines["cam"]
    sample = (track.frame - line.beta) / line.alpha
    seen = np.interp(sample, out.trajectory.sample, out.trajectory.xyz[:, 0])
    inside = (sample >= 0) & (sample <= out.trajectory.sample[-1])
    assert np.abs(track.x[inside] - seen[inside]).max() < 1e-6


def test_crop_keeps_a_window_of_each_visit_renumbered():
    cameras, log, lines, n_frames = flight()
    other = Camera(name="b", K=np.eye(3), dist=np.zeros(5), R=np.eye(3), t=np.zeros(3), image_size=(100, 100))
    cameras["b"] = CameraInput(other, cameras["cam"].track, 30.0)
    lines["b"], n_frames["b"] = lines["cam"], n_frames["cam"]
    whole = slowed_flight(cameras, log, lines, n_frames, time_warp(79.8, 1.0))
    out = cropped(whole, 0.25)
    for name, starts_at in (("cam", 0), ("b", 899)):  # the first keeps the visit's start, the last its end
        track, line = out.cameras[name].track, out.lines[name]
        assert track.frame[0] == 0 and abs(len(track) - 300) <= 1 and out.n_frames[name] == track.frame[-1] + 1
        assert np.allclose(track.x, whole.cameras[name].track.x[starts_at : starts_at + len(track)])
        sample = (track.frame - line.beta) / line.alpha
        assert np.allclose(track.x, SPEED * sample / RATE)
