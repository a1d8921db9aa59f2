"""Breaks found in a recording: the container's gaps and repeats, frozen pictures (trackers/breaks.py)."""

import numpy as np

from trackers.breaks import Break, FreezeMeter, container_breaks, frozen_runs


def test_container_gap_and_repeat():
    times = np.arange(100) / 25.0
    times[40:] += 10 / 25.0  # ten frames missing before frame 40
    times[70:72] = times[69]  # frames 70 and 71 stamped as 69
    times[72:] -= 2 / 25.0
    found = container_breaks(times, 25.0)
    assert found == [Break("gap", 40, 10.0), Break("repeat", 70, 2.0)]


def test_steady_and_jittered_times_have_no_break():
    rng = np.random.default_rng(0)
    steady = np.arange(300) / 30.0
    jittered = np.cumsum(np.full(300, 1 / 30.0) * (1 + 0.1 * rng.uniform(-1, 1, 300)))
    assert container_breaks(steady, 30.0) == []
    assert container_breaks(jittered) == []


def _noisy_frames(n, rng, moving=True):
    base = rng.integers(40, 200, (60, 80)).astype(np.int16)
    for k in range(n):
        frame = base + rng.normal(0, 3, base.shape)
        if moving:
            frame[20:30, k % 70 : k % 70 + 10] = 250  # a moving bright square
        yield np.clip(frame, 0, 255).astype(np.uint8)


def test_freeze_meter_finds_a_frozen_run_where_the_picture_moved():
    rng = np.random.default_rng(1)
    frames = list(_noisy_frames(80, rng))
    frozen = frames[:30] + [frames[29]] * 12 + frames[30:]  # a stall of 12 frames after frame 29
    meter = FreezeMeter()
    for k, gray in enumerate(frozen):
        meter.feed(k, gray, True)
    assert meter.breaks() == [Break("frozen", 30, 12.0)]


def test_a_freeze_meter_fed_a_clean_video_finds_none():
    meter = FreezeMeter()
    for k, gray in enumerate(_noisy_frames(80, np.random.default_rng(2))):
        meter.feed(k, gray, True)
    assert meter.breaks() == []


def test_a_still_scene_without_a_mover_is_not_a_freeze():
    """Unchanged pictures between moving ones: a freeze when they hold a mover (the stalled picture still shows
    it), not when the target left the view and came back (a still scene coded at a low rate)."""
    change = np.array([90] * 20 + [3] * 10 + [90] * 20 + [0, 2] + [90] * 5 + [30, 5, 12, 30] + [90] * 3)
    movers = np.ones(len(change), bool)
    movers[20:30] = False  # the target out of view
    found = frozen_runs(np.arange(1, len(change) + 1), change, movers)
    assert found == [Break("frozen", 51, 2.0)]  # the 5, 12 run is not framed by moving frames (30 < 40 either side)


def test_coding_noise_of_a_repeated_picture_is_still():
    change = np.array([90] * 5 + [3, 17, 0, 9] + [90] * 5)
    assert frozen_runs(np.arange(len(change)), change, np.ones(len(change), bool)) == [Break("frozen", 5, 4.0)]


def test_break_round_trip_and_words():
    b = Break("frozen", 412, 25.0)
    assert Break.from_dict(b.to_dict()) == b
    assert b.describe() == "frozen 25 frames at frame 412"
