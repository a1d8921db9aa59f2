"""Breaks found in a recording: the container's gaps and repeats, frozen pictures (trackers/breaks.py)."""

import numpy as np

from trackers.breaks import (
    Break,
    KeyframeMeter,
    PictureMeter,
    check_spans,
    container_breaks,
    frozen_runs,
    keyframe_flicker,
    keyframe_suspects,
    repeated_frames,
    scene_cuts,
    still_packet_runs,
)


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
    meter = PictureMeter()
    for k, gray in enumerate(frozen):
        meter.feed(k, gray, True)
    assert meter.breaks() == [Break("frozen", 30, 12.0)]


def test_a_freeze_meter_fed_a_clean_video_finds_none():
    meter = PictureMeter()
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


def _textured(rng, h=120, w=160):
    return rng.integers(40, 200, (h, w)).astype(np.float64)


def _meter_breaks(frames):
    meter = PictureMeter()
    for k, gray in enumerate(frames):
        meter.feed(k, np.clip(gray, 0, 255).astype(np.uint8), True)
    return meter.breaks()


def _scene(rng, n, gains=None, base=None, square=True):
    """Frames of a textured scene with sensor noise, a square moving to and fro and a global gain per frame."""
    base = _textured(rng) if base is None else base
    gains = np.ones(n) if gains is None else gains
    for k in range(n):
        frame = base.copy()
        x = abs(2 * k % 280 - 140)
        if square:
            frame[40:60, x : x + 20] = 250
        yield frame * gains[k] + rng.normal(0, 2, base.shape)


def test_a_restart_in_other_light_is_a_cut():
    rng = np.random.default_rng(3)
    base = _textured(rng)
    earlier = list(_scene(rng, 40, gains=np.full(40, 0.8), base=base))
    later = list(_scene(rng, 60, base=base))[40:]
    assert _meter_breaks(earlier + later) == [Break("cut", 40, 0.0)]


def test_a_restart_after_a_car_left_is_a_cut():
    rng = np.random.default_rng(4)
    base = _textured(rng)
    parked = base.copy()
    parked[70:90, 20:100] = 30  # a car parked in the earlier recording
    frames = list(_scene(rng, 30, base=parked)) + list(_scene(rng, 60, base=base))[30:]
    assert _meter_breaks(frames) == [Break("cut", 30, 0.0)]


def test_flicker_a_flash_and_a_mover_passing_close_are_no_cut():
    rng = np.random.default_rng(5)
    n = 400
    gains = 1.0 + 0.06 * np.sin(2 * np.pi * np.arange(n) / 37.0) + 0.018 * rng.standard_normal(n)
    gains[200] *= 1.5  # a flash: one frame far brighter, then back
    frames = list(_scene(rng, n, gains=gains))
    for k in range(300, 345):  # a walker close to the camera crossing the picture (a third of it wide)
        frames[k][:, max(0, 5 * (k - 300) - 60) : 5 * (k - 300)] = 20
    assert [b for b in _meter_breaks(frames) if b.kind == "cut"] == []


def test_scene_cuts_needs_the_frames_either_side():
    frames = np.array([1, 2, 3, 5, 6])
    step = np.array([[0.1, 0.0], [0.1, 0.0], [9.0, 0.5], [0.1, 0.0], [0.1, 0.0]])
    across = np.full((5, 2), 9.0)
    assert scene_cuts(frames, step, across) == []  # frame 3's next frame (4) was not read
    frames = np.array([1, 2, 3, 4, 5])
    assert scene_cuts(frames, step, across) == [Break("cut", 3, 0.0)]
    across[3] = (0.2, 0.0)  # frame 4 is back to what frame 1 showed: a flash, not a cut
    assert scene_cuts(frames, step, across) == []


def test_a_cut_in_words():
    assert Break("cut", 15, 0.0).describe() == "a cut (the picture changes at once) at frame 15"


def test_a_keyframe_coded_afresh_inside_a_freeze_does_not_split_it():
    """A keyframe changes pixels by up to 30 levels when it codes a repeated picture afresh: inside a run whose
    frames converge on it (a third or more repeating it exactly) it is part of the freeze; in a still scene whose
    noise moves a pixel by 1-10 levels in most frames (crf 35) it is not; a keyframe that moves by 40 levels is a
    moving frame."""
    change = np.array([90] * 5 + [30] + [4, 3, 4, 5] + [0] * 6 + [90] * 5)
    keyframe = np.zeros(len(change), bool)
    keyframe[5] = True
    movers = np.ones(len(change), bool)
    frames = np.arange(len(change))
    assert frozen_runs(frames, change, movers) == []  # 30 levels: neither still nor moving, the run is not framed
    assert frozen_runs(frames, change, movers, keyframe) == [Break("frozen", 5, 11.0)]
    noisy = change.copy()
    noisy[10:14] = [3, 9, 5, 2]
    assert frozen_runs(frames, noisy, movers, keyframe) == []
    moving = change.copy()
    moving[5] = 45
    assert frozen_runs(frames, moving, movers, keyframe) == [Break("frozen", 6, 10.0)]  # it moved: the run follows


def test_packets_coded_to_nothing_and_keyframe_jumps_are_spans_to_check():
    sizes = np.array([9000] + [600] * 20 + [30] * 12 + [600] * 20 + [30] + [600] * 10)
    keyframe = np.zeros(len(sizes), bool)
    keyframe[0] = True
    assert still_packet_runs(sizes, keyframe) == [(21, 33)]  # the lone small packet is no run
    frames = [0, 60, 120, 180, 240, 300]
    step = np.array([[1.0, 0.01], [6.0, 0.01], [1.0, 0.01], [1.2, 0.2], [1.0, 0.01]])
    assert keyframe_suspects(frames, step) == [(60, 120), (180, 240)]
    assert keyframe_suspects(frames[:2], step[1:2]) == [(0, 60)]  # a lone step is judged by its floor alone
    windows = ((700, 900),)
    assert check_spans([(60, 120), (100, 130), (750, 760), (995, 1000)], windows, 998) == ((57, 133), (992, 998))


def test_a_flickering_light_between_keyframes_is_no_suspect_a_restart_in_other_light_is():
    """Keyframes 120 frames apart under the long fixtures' light (6 % flicker over 37 frames, 1.8 % noise): their
    brightness steps stand out of their neighbours' by chance, never beyond the flicker; a restart whose earlier
    light was 0.65 of the later does. Under a steady light a 4 % step is a suspect."""
    rng = np.random.default_rng(0)
    n = 7200
    gains = 1.0 + 0.06 * np.sin(2 * np.pi * np.arange(n) / 37.0) + 0.018 * rng.standard_normal(n)
    frames = list(range(0, n, 120))

    def steps(light):
        brightness = np.log(light[frames])
        return np.column_stack([np.full(len(frames) - 1, 0.8), np.abs(np.diff(brightness))])

    flickering = steps(gains)
    assert len(keyframe_suspects(frames, flickering)) > 5  # judged by the floor alone, flicker spikes are read
    assert keyframe_suspects(frames, flickering, keyframe_flicker(flickering)) == []
    restarted = steps(np.where(np.arange(n) < 3630, 0.65, 1.0) * gains)
    assert keyframe_suspects(frames, restarted, keyframe_flicker(restarted)) == [(3600, 3720)]
    steady = steps(np.where(np.arange(n) < 3630, 0.96, 1.0) * (1.0 + 0.002 * rng.standard_normal(n)))
    assert keyframe_suspects(frames, steady, keyframe_flicker(steady)) == [(3600, 3720)]
    assert keyframe_flicker(np.zeros((0, 2))) == 0.0


def test_the_frames_of_frozen_runs_and_repeated_times():
    breaks = [Break("frozen", 10, 3.0), Break("gap", 40, 5.0), Break("repeat", 50, 1.0), Break("cut", 60, 0.0)]
    assert repeated_frames(breaks).tolist() == [10, 11, 12, 50]
    assert repeated_frames([]).size == 0


def test_the_keyframe_meter_judges_each_pass_of_the_coarse_pass_on_its_own():
    """Keyframes 4 s apart, then those between in a second pass: a car leaving between frames 120 and 150 is a
    suspect between the keyframes read either side of it, in each pass."""
    rng = np.random.default_rng(0)
    base = rng.integers(60, 200, (240, 320)).astype(np.uint8)
    meter = KeyframeMeter()

    def picture(index):
        out = base.copy()
        if index < 130:
            out[100:140, 40:200] = 40  # a parked car, gone at frame 130
        return out

    for index in (*range(0, 301, 60), *range(30, 301, 60)):
        meter.feed(index, picture(index))
    assert meter.suspects() == [(90, 150), (120, 180)]
