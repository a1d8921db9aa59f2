"""Before/after band-swap pictures of one camera, meaningful without overlapping views (paper Fig. 4 idea).

Each panel puts the real frame's brightness in the red band and a rendering
of the target (a disc of the tracked size at the trajectory's projected
position) in the green band. Where the rendered target lies on the real one
the two add up to yellow; where they do not, a red and a green blob stand
apart (a double exposure), and their distance is the synchronization error
seen in the image.

- after: the target rendered at the sample the camera line gives the frame
  (the synchronized time);
- before: the target rendered at the frame's own time taken as time on the
  log (frame index / fps, or the presentation time for VFR, from the log's
  first sample): what one sees without synchronization.

Pure functions: images and values in, images out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DEFAULT_RADIUS_PX = 6.0
PANEL_HEIGHT = 240  # pixels of each frame in the pictures
CAPTION_HEIGHT = 22
LINE_STEP = 16  # pixels between the lines of a two-line caption
MIN_TEXT_SCALE = 0.3
_FONT = 0  # cv2.FONT_HERSHEY_SIMPLEX (OpenCV loads with the first picture drawn, not with the module)


@dataclass(frozen=True)
class Panel:
    """One frame's panel: the frame (BGR), the rendered target's position (px, None when not in view), caption."""

    image: np.ndarray
    target_uv: tuple[float, float] | None
    caption: str


def target_radius(track) -> float:
    """Half the tracked box's median size (px), or DEFAULT_RADIUS_PX without boxes."""
    if track.w is None or track.h is None or len(track) == 0:
        return DEFAULT_RADIUS_PX
    return max(3.0, 0.5 * float(np.median(np.maximum(track.w, track.h))))


def band_swap_target(frame: np.ndarray, target_uv: tuple[float, float] | None, radius: float) -> np.ndarray:
    """Red: the frame's brightness; green: a disc of ``radius`` px at ``target_uv`` (BGR out, frame's size)."""
    import cv2

    gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
    render = np.zeros_like(gray)
    if target_uv is not None:
        center = (int(round(target_uv[0] * 4)), int(round(target_uv[1] * 4)))
        cv2.circle(render, center, int(round(radius * 4)), 255, -1, cv2.LINE_AA, shift=2)
    return np.dstack([np.zeros_like(gray), render, gray])


def caption_layout(text: str, width: int) -> tuple[list[str], float]:
    """How ``text`` fits above an image ``width`` px wide: its lines (one, or two split before a parenthesis or at
    the space nearest the middle: never cut) and the font scale."""
    room = 0.9 * (width - 8)

    def widest(lines: list[str], scale: float) -> int:
        import cv2

        return max(cv2.getTextSize(line, _FONT, scale, 1)[0][0] for line in lines)

    layouts = [[text]]
    spaces = [i for i, c in enumerate(text) if c == " "]
    if spaces:
        cut = text.rfind(" (") if text.rfind(" (") > 0 else min(spaces, key=lambda i: abs(i - len(text) / 2))
        layouts.append([text[:cut], text[cut + 1 :]])
    for lines in layouts:
        scale = 0.45
        while scale > MIN_TEXT_SCALE and widest(lines, scale) > room:
            scale *= 0.95
        if widest(lines, scale) <= room:
            return lines, scale
    while widest(lines, scale) > room:  # narrower than any readable caption: smaller still, never cut
        scale *= 0.95
    return lines, scale


def caption(image: np.ndarray, text: str, lines: int = 1) -> np.ndarray:
    """The image with a white bar above it holding ``text`` in black, whole: shrunk, or on two lines
    (caption_layout); the bar holds at least ``lines`` lines, so that panels side by side stay aligned."""
    import cv2

    width = image.shape[1]
    rows, scale = caption_layout(text, width)
    bar = np.full((CAPTION_HEIGHT + LINE_STEP * (max(lines, len(rows)) - 1), width, 3), 255, np.uint8)
    for i, row in enumerate(rows):
        cv2.putText(bar, row, (4, CAPTION_HEIGHT - 7 + LINE_STEP * i), _FONT, scale, (0, 0, 0), 1, cv2.LINE_AA)
    return np.vstack([bar, image])


def fit_height(image: np.ndarray, height: int = PANEL_HEIGHT) -> tuple[np.ndarray, float]:
    """The image resized to ``height`` pixels high, and the scale applied."""
    import cv2

    scale = height / image.shape[0]
    size = (max(1, round(image.shape[1] * scale)), height)
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA), scale


def panel_image(panel: Panel, radius: float, lines: int = 1) -> np.ndarray:
    """A panel drawn at PANEL_HEIGHT with its caption (a bar of at least ``lines`` lines)."""
    swapped = band_swap_target(panel.image, panel.target_uv, radius)
    fitted, _ = fit_height(swapped)
    return caption(fitted, panel.caption, lines)


def mosaic(rows: list[list[np.ndarray]], gap: int = 4) -> np.ndarray:
    """Rows of images on a white ground, left-aligned, ``gap`` pixels apart."""
    heights = [max(img.shape[0] for img in row) for row in rows]
    widths = [sum(img.shape[1] for img in row) + gap * (len(row) - 1) for row in rows]
    out = np.full((sum(heights) + gap * (len(rows) - 1), max(widths), 3), 255, np.uint8)
    y = 0
    for row, height in zip(rows, heights):
        x = 0
        for img in row:
            out[y : y + img.shape[0], x : x + img.shape[1]] = img
            x += img.shape[1] + gap
        y += height + gap
    return out


def before_after(rows: list[tuple[Panel, Panel]], radius: float) -> np.ndarray:
    """The picture: one row per frame, before on the left, after on the right (captions of a row as many lines)."""
    out = []
    for before, after in rows:
        width = round(before.image.shape[1] * PANEL_HEIGHT / before.image.shape[0])
        lines = max(len(caption_layout(panel.caption, width)[0]) for panel in (before, after))
        out.append([panel_image(before, radius, lines), panel_image(after, radius, lines)])
    return mosaic(out)
