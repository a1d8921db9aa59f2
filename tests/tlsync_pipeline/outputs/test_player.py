"""The player's data: compact frame times, the projected path on the target grid, the recording range."""

import numpy as np
import pytest

from data_fixtures import make_scene
from tlsync_pipeline.outputs.player import (
    PlayerVideo,
    decode_times,
    encode_times,
    player_data,
    projected_path,
    recording_samples,
)
from tlsync_pipeline.sync.model.clock import TIME_S, CameraClock, FrameTimes, Segment
from tlsync_pipeline.sync.timeline import CameraLine, Timeline
from tlsync_pipeline.trajectory import Trajectory
from trackers.breaks import Break


def test_regular_times_are_three_numbers_and_vfr_times_survive_to_the_microsecond():
    regular = 0.5 + np.arange(1000) / 29.97
    encoded = encode_times(regular)
    assert set(encoded) == {"start", "step", "n"}
    np.testing.assert_allclose(decode_times(encoded), regular, atol=1e-9)
    rng = np.random.default_rng(1)
    vfr = 0.37 + np.cumsum(rng.uniform(0.02, 0.05, 500))
    encoded = encode_times(vfr)
    assert "deltas_us" in encoded
    np.testing.assert_allclose(decode_times(encoded), vfr, atol=1e-6)


def test_recording_range_follows_the_clock():
    times = 0.5 + np.arange(101) / 30.0
    cfr = CameraLine("c", 2.0, 10.0, 0, 0, 0.0, 30.0)
    assert recording_samples(cfr, times) == pytest.approx((-5.0, 45.0))
    vfr = CameraLine("c", 2.0, 10.0, 0, 0, 0.0, 30.0, clock=CameraClock(TIME_S, 30.0))
    assert recording_samples(vfr, times) == pytest.approx(((15.0 - 10.0) / 2.0, (115.0 - 10.0) / 2.0))


def test_projected_path_is_null_in_gaps_and_matches_the_projection():
    scene = make_scene(seed=0)
    camera, line = scene.cameras["cam0"], scene.lines["cam0"]
    seen = (scene.tracks["cam0"].frame - line.beta) / line.alpha  # samples where the target is in view
    lo, hi = float(seen.min()), float(seen.max())
    gap = (lo + 0.4 * (hi - lo), lo + 0.6 * (hi - lo))
    full = scene.trajectory
    keep = (full.sample < gap[0]) | (full.sample > gap[1])
    path = projected_path(camera, Trajectory(full.sample[keep], full.xyz[keep], full.rate, full.t0), lo, hi)
    uv = np.array([np.nan if v is None else v / 10 for v in path["uv"]]).reshape(-1, 2)
    samples = path["start"] + path["step"] * np.arange(len(uv))
    assert samples[0] <= lo + 1 and samples[-1] >= hi - 1
    assert np.isnan(uv[(samples > gap[0]) & (samples < gap[1])]).all()
    outside = (samples < gap[0]) | (samples > gap[1])
    expected, valid = camera.project(full.xyz[np.searchsorted(full.sample, samples[outside])])
    assert valid.all()
    np.testing.assert_allclose(uv[outside], expected, atol=0.051)  # tenths of a pixel


def player_frame(entry: dict, sample: float) -> int:
    """player.js's locate() on a frame clock, from the emitted data: the frame, -1 not recording, -2 unknown segment."""
    clock = entry["alpha"] * sample + entry["beta"]
    n, segments = entry["times"]["n"], entry["segments"]
    for k, g in enumerate(segments):
        if g["shift"] is None:
            continue
        f = int(np.floor(clock - g["shift"] + 0.5))  # Math.round
        if 0 <= f < n and (k == 0 or f >= g["start"]) and (k == len(segments) - 1 or f < g["stop"]):
            return f

    def spans(g: dict) -> bool:
        return (g["lo"] is None or sample >= g["lo"]) and (g["hi"] is None or sample <= g["hi"])

    return -2 if any(g["shift"] is None and spans(g) for g in segments) else -1


def test_a_recording_that_breaks_is_played_through_its_segments_as_the_frame_map_maps_it():
    scene = make_scene(seed=0)
    names = list(scene.lines)[:2]
    n = 300
    segments = (
        Segment(0, 100, 0.0, "line", 40),
        Segment(100, 180, None, "unknown", 0),
        Segment(180, 300, 60.0, "votes", 30),
    )
    breaks = (Break("gap", 100, 3.0), Break("drop", 180, 57.0))
    broken = CameraLine(names[1], 2.0, 10.0, 0, 0, 0.0, 30.0, clock=CameraClock(segments=segments), breaks=breaks)
    steady = CameraLine(names[0], scene.lines[names[0]].alpha, scene.lines[names[0]].beta, 0, 0, 0.0, 30.0)
    timeline = Timeline({names[0]: steady, names[1]: broken}, target_rate=10.0, target_t0=0.0)
    videos = {name: PlayerVideo(None, False, None, np.arange(n) / 30.0) for name in names}
    data = player_data(timeline, scene.cameras, scene.trajectory, videos, utc=False)
    plain, entry = data["cameras"]
    assert "segments" not in plain and "breaks" not in plain  # a steady recording's entry is as before
    rows = entry["segments"]
    assert [(g["start"], g["stop"], g["shift"], g["source"]) for g in rows] == [
        (0, 100, 0.0, "line"),
        (100, 180, None, "unknown"),
        (180, 300, 60.0, "votes"),
    ]
    assert (rows[0]["lo"], rows[0]["hi"]) == pytest.approx(((0 - 10) / 2, (99 - 10) / 2))
    assert (rows[2]["lo"], rows[2]["hi"]) == pytest.approx(((180 + 60 - 10) / 2, (299 + 60 - 10) / 2))
    # the unknown segment lies between its known neighbours
    assert (rows[1]["lo"], rows[1]["hi"]) == (rows[0]["hi"], rows[2]["lo"])
    assert entry["breaks"] == [
        {"sample": pytest.approx(rows[0]["hi"]), "text": "gap of 3 frames at frame 100"},
        {"sample": pytest.approx(rows[2]["lo"]), "text": "jump of 57 frames at frame 180"},
    ]
    # every sample: the player's frame is the frame map's (CameraClock.frames_at), and none in the unknown segment
    table = FrameTimes(np.arange(n, dtype=np.float64), videos[names[1]].frame_times)
    samples = np.linspace(-20.0, 190.0, 4201)
    expected = np.floor(broken.clock.frames_at(2.0 * samples + 10.0, table) + 0.5)  # the nearest frame, ties up
    shown = np.array([player_frame(entry, s) for s in samples])
    known = np.isfinite(expected) & (expected >= 0) & (expected < n)
    np.testing.assert_array_equal(shown[known], expected[known])
    assert (shown[(samples > rows[0]["hi"] + 0.5) & (samples < rows[2]["lo"] - 0.5)] == -2).all()
    assert (shown[samples < rows[0]["lo"] - 0.5] == -1).all() and (shown[samples > rows[2]["hi"] + 0.5] == -1).all()
    second = rows[2]["lo"] + 10.0  # into the second known segment: its own shift, not the first segment's line
    assert player_frame(entry, second) == 180 + 20 and round(2.0 * second + 10.0) == 260
