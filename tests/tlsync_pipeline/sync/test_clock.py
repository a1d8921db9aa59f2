"""Camera clocks: frame indices or presentation time x fps, and the mapping between clock and frames."""

import numpy as np
import pytest

from tlsync_pipeline.sync.model.clock import FrameTimes, camera_clock
from trackers.track import Track


def test_camera_clock_and_its_frame_mapping():
    frames = np.arange(100)
    regular = Track(frames, frames * 1.0, frames * 1.0, time_s=frames / 30.0)
    assert not camera_clock(regular, 30.0).vfr
    jittered = 1.4 + np.r_[0.0, np.cumsum(1 + np.random.default_rng(0).uniform(-0.1, 0.1, 99))] / 30.0
    track = Track(frames, frames * 1.0, frames * 1.0, time_s=jittered)
    clock = camera_clock(track, 30.0)
    times = FrameTimes.of_track(track)
    assert clock.vfr and np.array_equal(clock.clock_at(frames, times), jittered * 30.0)
    assert np.allclose(clock.frames_at(clock.clock_at(frames + 0.3, times), times), frames + 0.3)
    # Without the times, the linear approximation: frames at 30 fps from the fitted origin (1.4 s).
    assert clock.origin_s == pytest.approx(1.4, abs=1 / 30.0)
    assert np.max(np.abs(clock.frames_at(jittered * 30.0) - frames)) < 2.0
    # Beyond the listed frames the clock continues at the nominal rate.
    assert clock.frames_at(jittered[-1] * 30.0 + 3.0, times) == pytest.approx(102.0)
