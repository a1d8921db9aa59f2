"""The player's proxies: every frame, or a long recording's windows with a card at each gap."""

import numpy as np
import pytest

from data_fixtures.video import render_video
from tlsync_pipeline.outputs.proxy import make_proxy
from trackers.video import iter_frames, presentation_times, probe_video


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    return render_video(tmp_path_factory.mktemp("proxy") / "clip.mp4", n_frames=90, jitter=0.3, seed=4)


def test_a_proxy_keeps_every_frame_and_its_time(clip, tmp_path):
    proxy = make_proxy(clip.path, tmp_path / "proxy.mp4", target_height=120)
    info = probe_video(proxy)
    assert (info.width, info.height, info.codec) == (160, 120, "h264")
    np.testing.assert_allclose(presentation_times(proxy), clip.times, atol=1e-4)


def test_a_windowed_proxy_holds_the_windows_and_a_card_per_gap(clip, tmp_path):
    proxy = make_proxy(clip.path, tmp_path / "proxy.mp4", target_height=120, windows=[(20, 40), (60, 70)])
    times = presentation_times(proxy)
    kept = [*range(20, 40), *range(60, 70)]
    cards = [0, 40, 70]  # before the first window, between the two, after the last
    np.testing.assert_allclose(times, clip.times[sorted(kept + cards)], atol=1e-4)
    frames = {round(f.time_s, 4): f.image for f in iter_frames(proxy, gray=True)}
    card = frames[round(float(clip.times[40]), 4)]
    assert np.median(card) == pytest.approx(96, abs=3)  # the grey card
    assert abs(float(np.median(frames[round(float(clip.times[20]), 4)])) - 96) > 5  # a picture of the scene
