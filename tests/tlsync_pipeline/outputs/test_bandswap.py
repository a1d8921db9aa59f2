"""Band swap against a rendered target: yellow where aligned, two blobs where not; captions drawn once and whole."""

import cv2
import numpy as np

from tlsync_pipeline.outputs import bandswap


def _frame_with_target(center, size=(160, 120), radius=6):
    rng = np.random.default_rng(0)
    image = rng.integers(40, 90, (size[1], size[0], 3), dtype=np.uint8)
    cv2.circle(image, center, radius, (250, 250, 250), -1)
    return image


def _yellow(image):
    """Pixels where both the red (real frame) and the green (rendered target) bands are bright."""
    return (image[..., 2] > 200) & (image[..., 1] > 200)


def test_aligned_target_turns_yellow_and_misaligned_shows_two_blobs():
    frame = _frame_with_target((100, 60))
    after = bandswap.band_swap_target(frame, (100.0, 60.0), 6.0)
    before = bandswap.band_swap_target(frame, (40.0, 30.0), 6.0)
    assert _yellow(after).sum() > 0.8 * np.pi * 6**2
    assert _yellow(before).sum() == 0
    green_only = (before[..., 1] > 200) & (before[..., 2] < 120)
    ys, xs = np.nonzero(green_only)
    assert abs(xs.mean() - 40) < 1 and abs(ys.mean() - 30) < 1
    assert (after[..., 0] == 0).all()  # blue is empty: only the two bands carry meaning


def test_target_out_of_view_leaves_the_green_band_empty():
    out = bandswap.band_swap_target(_frame_with_target((100, 60)), None, 6.0)
    assert (out[..., 1] == 0).all()
    assert (out[..., 2] == cv2.cvtColor(_frame_with_target((100, 60)), cv2.COLOR_BGR2GRAY)).all()


def test_caption_sits_above_the_image_whole_and_once():
    image = np.full((50, 200, 3), 128, np.uint8)
    long_text = "after: cam12 frame 12377 at log time 1234.56 s (target out of view)"
    lines, _ = bandswap.caption_layout(long_text, 200)
    assert lines == ["after: cam12 frame 12377 at log time 1234.56 s", "(target out of view)"]  # whole, never cut
    out = bandswap.caption(image, long_text)
    bar_height = bandswap.CAPTION_HEIGHT + bandswap.LINE_STEP
    assert out.shape == (50 + bar_height, 200, 3)
    assert (out[bar_height:] == image).all()  # nothing drawn over the picture
    ink = np.nonzero(out[:bar_height].min(axis=2) < 255)
    assert ink[1].min() >= 1 and ink[1].max() <= 200 - 2  # not clipped at either side
    assert ink[0].min() >= 1 and ink[0].max() <= bar_height - 2
    # drawn once, black on white: the old label was white over a thick black copy, shifted
    bar = out[:bar_height].astype(int)
    assert (bar[..., 0] == bar[..., 1]).all() and (bar[..., 1] == bar[..., 2]).all()
    assert bar.min() < 60 and np.mean(bar < 255) < 0.35
    short = bandswap.caption(image, "after: frame 3", lines=2)
    assert short.shape == out.shape  # a row's panels keep one bar height


def test_before_after_puts_one_row_per_frame():
    frame = _frame_with_target((100, 60))
    rows = [(bandswap.Panel(frame, (40.0, 30.0), "before"), bandswap.Panel(frame, (100.0, 60.0), "after"))] * 2
    picture = bandswap.before_after(rows, 6.0)
    panel_height = bandswap.PANEL_HEIGHT + bandswap.CAPTION_HEIGHT
    assert picture.shape[0] == 2 * panel_height + 4
    right = picture[bandswap.CAPTION_HEIGHT : panel_height, picture.shape[1] // 2 + 4 :]
    assert _yellow(right).sum() > 0
