"""report.html in a real browser (headless Chromium over the DevTools protocol).

Two cameras whose every frame shows its own index as a 12-bit block code:
cam0 constant-rate MPEG-4 part 2 (browsers cannot play it: the report links
an H.264 proxy), cam1 a variable-frame-rate H.264 stream whose presentation
times drift by up to 3 frames and start at 0.5 s (a phone). After a run, the
page must load without console errors; moving the shared slider must seek
every video to the frame the frame map names (currentTime inside that
frame's display interval, and the block code read from the pixels the
browser shows equal to it); the arrow key must step the chosen camera by one
frame; and a screenshot is written.
"""

from __future__ import annotations

import csv
import json
from fractions import Fraction

import av
import cv2
import numpy as np
import pytest

from data_fixtures import make_scene, write_scene
from tests.browser import Browser, find_chromium
from tlsync_pipeline.outputs.player import PlayerVideo, player_data
from tlsync_pipeline.outputs.report_content import ReportContent
from tlsync_pipeline.outputs.report_html import report_html
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.sync.model.clock import CameraClock, Segment
from tlsync_pipeline.sync.timeline import CameraLine, Timeline
from trackers.breaks import Break
from trackers.track import Track
from trackers.video import presentation_times

SIZE = (320, 240)
N_FRAMES = 360
VFR_START_S = 0.5
BITS = 12

CHROMIUM = find_chromium()
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium is not installed (.ci/run installs it: apt-get install chromium)"
)


def code_image(index: int) -> np.ndarray:
    """A dark frame with the index's 12 bits as white blocks, 6 x 2 cells over the top half."""
    w, h = SIZE
    image = np.full((h, w, 3), 30, np.uint8)
    cw, ch = w // 6, h // 4
    for bit in range(BITS):
        if (index >> bit) & 1:
            x, y = (bit % 6) * cw, (bit // 6) * ch
            image[y + ch // 5 : y + ch - ch // 5, x + cw // 5 : x + cw - cw // 5] = 235
    return image


def write_cfr_mpeg4(path, n_frames: int, fps: float) -> None:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, SIZE)
    for k in range(n_frames):
        writer.write(code_image(k))
    writer.release()


def write_vfr_h264(path, times: np.ndarray) -> None:
    base = Fraction(1, 90000)
    with av.open(str(path), "w") as output:
        stream = output.add_stream("libx264", rate=30)
        stream.width, stream.height, stream.pix_fmt = SIZE[0], SIZE[1], "yuv420p"
        stream.time_base = stream.codec_context.time_base = base
        for k, t in enumerate(times):
            frame = av.VideoFrame.from_ndarray(code_image(k), format="bgr24")
            frame.pts, frame.time_base = round(t / base), base
            for packet in stream.encode(frame):
                output.mux(packet)
        for packet in stream.encode():
            output.mux(packet)


def vfr_track(scene, name: str, times: np.ndarray) -> Track:
    """The target in a camera whose clock is its presentation times x fps (the truth for a VFR camera)."""
    camera, line = scene.true_cameras[name], scene.lines[name]
    sample = (times * camera.fps - line.beta) / line.alpha
    inside = (sample >= 0) & (sample <= scene.true_trajectory.sample[-1])
    xyz = np.column_stack(
        [np.interp(sample, scene.true_trajectory.sample, scene.true_trajectory.xyz[:, i]) for i in range(3)]
    )
    uv, valid = camera.project(xyz)
    keep = inside & valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
    frames = np.flatnonzero(keep)
    return Track(frames.astype(np.int64), uv[keep, 0], uv[keep, 1], time_s=times[keep])


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    folder = tmp_path_factory.mktemp("browser")
    scene = make_scene(seed=3, lines=((2.0, 4.0), (2.0, 45.0)), n_frames=N_FRAMES, image_size=SIZE)
    fps = scene.cameras["cam1"].fps
    k = np.arange(N_FRAMES)
    times = VFR_START_S + (k + 3.0 * np.sin(2 * np.pi * k / N_FRAMES)) / fps
    scene.tracks["cam0"] = Track(scene.tracks["cam0"].frame, scene.tracks["cam0"].x, scene.tracks["cam0"].y)
    scene.tracks["cam1"] = vfr_track(scene, "cam1", times)
    project = write_scene(scene, folder)
    write_cfr_mpeg4(folder / "cam0.mp4", N_FRAMES, scene.cameras["cam0"].fps)
    write_vfr_h264(folder / "cam1.mp4", times)
    text = project.read_text()
    for name in ("cam0", "cam1"):
        text = text.replace(f'track = "{name}/track.csv"\n', f'track = "{name}/track.csv"\nvideo = "{name}.mp4"\n')
    project.write_text(text)
    graph = build_graph(load_project(project), folder / "work")
    summary = run_graph(graph, targets=["render"])
    assert not summary.failed, summary.failed
    timeline = json.loads((graph.work / "timeline.json").read_text())
    assert timeline["cameras"]["cam1"].get("clock") == "time_s"  # the VFR camera runs on its presentation times
    return graph.work


PAGE_HELPERS = (
    """
window.__armSeeks = () => {
  // Promises of every video's next 'seeked' (or 5 s), set before the action that seeks.
  window.__seeks = window.tlsyncPlayer.views.map(view => new Promise(done => {
    view.video.addEventListener('seeked', done, {once: true});
    setTimeout(done, 5000);
  }));
};
window.__readViews = async () => {
  const player = window.tlsyncPlayer;
  await Promise.all(window.__seeks.filter((_, i) => player.views[i].frame >= 0));
  await new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)));
  const canvas = document.createElement('canvas');
  return player.views.map(view => {
    const v = view.video, w = v.videoWidth, h = v.videoHeight;
    canvas.width = w; canvas.height = h;
    const ctx = canvas.getContext('2d');
    ctx.drawImage(v, 0, 0, w, h);
    const pixels = ctx.getImageData(0, 0, w, h).data;
    let code = 0;
    for (let bit = 0; bit < %d; bit++) {
      const x = Math.floor(((bit %% 6) + 0.5) * w / 6), y = Math.floor((Math.floor(bit / 6) + 0.5) * h / 4);
      if (pixels[(y * w + x) * 4] > 128) code |= (1 << bit);
    }
    return {camera: view.camera.name, frame: view.frame, time: v.currentTime, code: code};
  });
};
"""
    % BITS
)


def move_slider(browser: Browser, position: float) -> dict[str, dict]:
    """Set the shared slider as a user would (an input event) and read every view back (frame,
    currentTime, code shown).
    """
    browser.evaluate("window.__armSeeks()")
    browser.evaluate(
        f"(() => {{ const s = document.getElementById('player-slider'); s.value = {float(position)!r}; "
        f"s.dispatchEvent(new Event('input')); }})()"
    )
    return {v["camera"]: v for v in browser.evaluate("window.__readViews()")}


def press(browser: Browser, key: str, code: int) -> dict[str, dict]:
    """Press a key in the page (DevTools input events) and read every view back."""
    browser.evaluate("window.__armSeeks()")
    browser.call("Input.dispatchKeyEvent", type="keyDown", key=key, code=key, windowsVirtualKeyCode=code)
    browser.call("Input.dispatchKeyEvent", type="keyUp", key=key, code=key, windowsVirtualKeyCode=code)
    return {v["camera"]: v for v in browser.evaluate("window.__readViews()")}


def read_frame_map(work) -> dict[tuple[str, int], dict]:
    with (work / "exports" / "frame_map.csv").open() as handle:
        return {(row["camera"], int(row["frame"])): row for row in csv.DictReader(handle)}


def test_report_in_chromium(report, tmp_path):
    work = report
    frame_map = read_frame_map(work)
    played = {"cam0": work / "render" / "proxy" / "cam0.mp4", "cam1": work.parent / "cam1.mp4"}
    assert played["cam0"].exists()  # MPEG-4 part 2: the player gets an H.264 proxy
    times = {name: presentation_times(path) for name, path in played.items()}
    with Browser(CHROMIUM, width=1280, height=1400) as browser:
        browser.navigate((work / "report.html").as_uri())
        ready = browser.evaluate(
            "Promise.all([...document.querySelectorAll('#player-views video')].map(v => v.readyState >= 2 ? 1 :"
            " new Promise((ok, fail) => { v.addEventListener('loadeddata', () => ok(1)); v.addEventListener('error', "
            "() => fail(v.src)); })))"
        )
        assert ready == [1, 1]
        browser.evaluate(PAGE_HELPERS)
        checked = 0
        for frame_b in (60, 150, 240, 300):
            row = frame_map[("cam1", frame_b)]
            views = move_slider(browser, float(row["sample"]))
            expected = {"cam1": frame_b}
            if row["frame_cam0"]:
                expected["cam0"] = int(round(float(row["frame_cam0"])))
            for name, frame in expected.items():
                view = views[name]
                assert view["frame"] == frame, (name, frame_b, view)
                start = times[name][frame]
                end = times[name][frame + 1] if frame + 1 < len(times[name]) else start + 1 / 30
                assert start <= view["time"] < end, (
                    name,
                    frame,
                    view["time"],
                    start,
                    end,
                )  # within one frame of the frame map
                assert view["code"] == frame, (name, frame, view)  # and the browser shows that very frame
                checked += 1
        assert checked >= 6
        # → steps the reference camera (cam0) by one frame; the other view follows through the frame map
        row = next(
            r
            for (name, _), r in frame_map.items()
            if name == "cam0" and r["frame_cam1"] and 100 < float(r["frame_cam1"]) < 200
        )
        before = move_slider(browser, float(row["sample"]))
        after = press(browser, "ArrowRight", 39)
        stepped = before["cam0"]["frame"] + 1
        assert after["cam0"]["frame"] == stepped and after["cam0"]["code"] == stepped
        expected_b = int(
            round(float(frame_map[("cam0", stepped)]["frame_cam1"]))
        )  # the other view follows the frame map
        assert after["cam1"]["frame"] == expected_b and after["cam1"]["code"] == expected_b, (before, after)
        assert browser.errors() == []
        screenshot = browser.screenshot()
    path = tmp_path / "report.png"
    path.write_bytes(screenshot)
    image = cv2.imread(str(path))
    assert (
        image is not None and 1240 <= image.shape[1] <= 1280 and image.shape[0] > 1400
    )  # the whole page (less a scrollbar)
    assert image.std() > 20  # a page, not a blank


def test_a_recording_that_breaks_plays_each_segment_at_its_own_time(tmp_path):
    """One H.264 camera whose recording breaks twice: frames 100-179 of unknown offset, then 57 frames dropped (frames
    180-299 shifted 60 frames on the line). Seeking into the last segment shows the frame its shift names (not the
    first segment's line's), the unknown segment shows no picture, and the strip marks both breaks."""
    scene = make_scene(seed=3, n_frames=N_FRAMES, image_size=SIZE)
    n = 300
    write_vfr_h264(tmp_path / "broken.mp4", np.arange(n) / 30.0)
    segments = (
        Segment(0, 100, 0.0, "line", 40),
        Segment(100, 180, None, "unknown", 0),
        Segment(180, 300, 60.0, "votes", 30),
    )
    breaks = (Break("gap", 100, 3.0), Break("drop", 180, 57.0))
    line = CameraLine("cam0", 2.0, 10.0, 0, 0, 0.0, 30.0, clock=CameraClock(segments=segments), breaks=breaks)
    timeline = Timeline({"cam0": line}, target_rate=10.0, target_t0=0.0)
    videos = {"cam0": PlayerVideo("broken.mp4", False, "h264", presentation_times(tmp_path / "broken.mp4"))}
    player = player_data(timeline, scene.cameras, scene.trajectory, videos, utc=False)
    page = report_html(ReportContent("broken", timeline, [], [], [], player=player))
    (tmp_path / "report.html").write_text(page, encoding="utf-8")
    with Browser(CHROMIUM) as browser:
        browser.navigate((tmp_path / "report.html").as_uri())
        loaded = (
            "new Promise(ok => { const v = document.querySelector('#player-views video');"
            " if (v.readyState >= 2) ok(1); else v.addEventListener('loadeddata', () => ok(1)); })"
        )
        assert browser.evaluate(loaded) == 1
        browser.evaluate(PAGE_HELPERS)
        for frame in (50, 200, 280):  # the first segment, then the last (its clock = frame + 60)
            clock = frame + (60 if frame >= 180 else 0)
            view = move_slider(browser, (clock - 10.0) / 2.0)["cam0"]
            assert view["frame"] == frame and view["code"] == frame, (frame, view)
            assert frame / 30.0 <= view["time"] < (frame + 1) / 30.0
        unknown = move_slider(browser, (140 + 30 - 10.0) / 2.0)["cam0"]  # between the two known segments
        assert unknown["frame"] == -2
        caption = browser.evaluate("document.querySelector('#player-views figcaption').textContent")
        assert "no picture: unknown segment" in caption
        assert browser.evaluate("document.querySelectorAll('#player-views .strip .break').length") == 2
        assert browser.errors() == []
