"""Breaks the pictures show (trackers/breaks.py, ``PictureMeter``): false ones on clean videos, found ones on edited.

Clean families, every frame read through every-mover detection (as the
track stage reads them, the detector telling the meter which frames hold a
mover): the synthetic camera video (``data_fixtures.video.render_video``:
textured background, a flicker of 6 % with 1.8 % of it changing from frame
to frame, an occluder, a distractor), the same under a steady light (0.5 %
flicker), as a phone's (10 % interval jitter) and compressed (crf 23, 28 and
35); the long-recording video (``data_fixtures.long_video``: two
look-alikes wandering, 1500 frames); the crowd cameras (``data_fixtures.crowd``: walkers up to 100 px tall passing
close, a cloud dimming the light by 20 % over 1.5 s). Per family: videos,
frames, frozen runs and cuts found (every one is false).

Edited: each clean synthetic camera video (both lights) cut and restarted
at three frames where the target is in view (``data_fixtures.breaks``,
``restart``: the earlier recording's light 0.85, 0.9 or 0.95 times the
later's, or a car
parked in it that has left), and frozen 5 or 25 frames at the same frames
(a freeze while nothing moves cannot be told from a still scene); per
edit, how many are found at their frame (within a frame), and the other
breaks found in the edited videos.

Cost: the meter's ``feed`` per 1080p luma frame against the freeze's
measure alone (the largest pixel change since the previous frame), in the
same run, three rounds.

    python bench/picture_breaks.py [--seeds 3]
"""

from __future__ import annotations

import argparse
import itertools
import tempfile
import time
from pathlib import Path

import numpy as np

from data_fixtures.breaks import BreakEdit, edit_video
from data_fixtures.crowd import CrowdSpec, make_crowd_scene
from data_fixtures.long_video import render_long_video, wandering_paths
from data_fixtures.video import loop_positions, render_video
from tlsync_pipeline.sync.identify.breaks import merged
from trackers.breaks import Break, PictureMeter
from trackers.tracking import detect_movers
from trackers.video import keyframe_indices, presentation_times

FPS = 25.0
CRFS = (23, 28, 35)  # the compressed families' H.264 crf
EDITS = {
    "restart, light 0.85": lambda at: BreakEdit("restart", at, 4500, light=0.85),
    "restart, light 0.9": lambda at: BreakEdit("restart", at, 4500, light=0.9),
    "restart, light 0.95": lambda at: BreakEdit("restart", at, 4500, light=0.95),
    "restart, a car left": lambda at: BreakEdit("restart", at, 4500, parked=True),
    "frozen 5": lambda at: BreakEdit("frozen", at, 5),
    "frozen 25": lambda at: BreakEdit("frozen", at, 25),
}


def picture_breaks(path: Path) -> tuple[list[Break], list[Break]]:
    """The frozen runs and cuts every-mover detection's reading of ``path`` finds (a cut at a freeze's edge is that
    freeze, as for the sync stage: ``merged``), and those found without the keyframes' rule (``frozen_runs``: every
    frame held to STILL_LEVELS), the baseline."""
    meter = PictureMeter()
    detect_movers(path, progress=False, meter=meter)
    keys = keyframe_indices(path)
    return list(merged(tuple(meter.breaks(() if keys is None else keys)))), list(merged(tuple(meter.breaks())))


def in_view_frames(in_view: np.ndarray, count: int = 3) -> list[int]:
    """``count`` frames spread over those with the target in view on the 3 frames either side."""
    steady = np.flatnonzero(np.convolve(in_view.astype(int), np.ones(7, int), mode="same") == 7)
    return [int(steady[round(q * (len(steady) - 1))]) for q in np.linspace(0.2, 0.8, count)]


def clean_videos(folder: Path, seeds: int) -> tuple[dict[str, list[Path]], dict[Path, list[int]]]:
    """The clean families' videos, rendered into ``folder``, and the camera videos' frames to edit."""
    out: dict[str, list[Path]] = {
        "camera": [],
        "camera, steady light": [],
        "phone (10 % jitter)": [],
        **{f"compressed (crf {crf})": [] for crf in CRFS},
        "long": [],
        "crowd": [],
    }
    edit_at = {}
    for seed in range(seeds):
        camera = render_video(folder / f"camera{seed}.mp4", seed=seed, fps=FPS)
        out["camera"].append(camera.path)
        edit_at[camera.path] = in_view_frames(camera.in_view)
        steady = render_video(folder / f"steady{seed}.mp4", seed=seed, fps=FPS, flicker=0.005)
        out["camera, steady light"].append(steady.path)
        edit_at[steady.path] = in_view_frames(steady.in_view)
        out["phone (10 % jitter)"].append(
            render_video(folder / f"phone{seed}.mp4", seed=seed, fps=FPS, jitter=0.1).path
        )
        for crf in CRFS:
            out[f"compressed (crf {crf})"].append(
                render_video(folder / f"crf{crf}_{seed}.mp4", seed=seed, fps=FPS, crf=crf).path
            )
        positions = loop_positions(1500, (320, 240))
        others = wandering_paths(np.random.default_rng(seed), 1500, (320, 240), 2.0, 2)
        out["long"].append(
            render_long_video(
                folder / f"long{seed}.mp4", positions, (320, 240), 15.0, radius=5.0, seed=seed, look_alikes=others
            )
        )
        crowd = folder / f"crowd{seed}"
        make_crowd_scene(CrowdSpec(seed=seed), crowd)
        out["crowd"] += sorted(crowd.glob("*.mp4"))
    return out, edit_at


def cost_per_frame(rounds: int = 3, frames: int = 200) -> list[tuple[float, float]]:
    """(meter, freeze's measure alone) ms per 1080p luma frame, per round."""
    import cv2

    rng = np.random.default_rng(0)
    planes = [rng.integers(0, 256, (1080, 1920), dtype=np.uint8) for _ in range(10)]
    out = []
    for _ in range(rounds):
        meter = PictureMeter()
        started = time.perf_counter()
        for k in range(frames):
            meter.feed(k, planes[k % 10], True)
        fed = (time.perf_counter() - started) / frames
        started = time.perf_counter()
        for k in range(1, frames + 1):
            int(cv2.absdiff(planes[k % 10], planes[(k - 1) % 10]).max())
        out.append((1000 * fed, 1000 * (time.perf_counter() - started) / frames))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="videos per family (seeds)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="tlsync-picture-breaks-") as tmp:
        folder = Path(tmp)
        videos, edit_at = clean_videos(folder, args.seeds)
        print("| clean family | videos | frames | frozen found | baseline: without the keyframes' rule | cuts found |")
        print("|---|---|---|---|---|---|")
        for family, paths in videos.items():
            frames, frozen, baseline, cuts = 0, [], [], []
            for path in paths:
                times = presentation_times(path)
                frames += 0 if times is None else len(times)
                found, without = picture_breaks(path)
                frozen += [f"{path.stem}:{b.frame}" for b in found if b.kind == "frozen"]
                baseline += [f"{path.stem}:{b.frame}" for b in without if b.kind == "frozen"]
                cuts += [f"{path.stem}:{b.frame}" for b in found if b.kind == "cut"]
            print(
                f"| {family} | {len(paths)} | {frames} | {len(frozen)} {' '.join(frozen)} "
                f"| {len(baseline)} {' '.join(baseline)} | {len(cuts)} {' '.join(cuts)} |",
                flush=True,
            )
        print()
        print("| edit | camera videos | edits | found at its frame | baseline | other breaks found | baseline |")
        print("|---|---|---|---|---|---|---|")
        for (label, make), family in itertools.product(EDITS.items(), ("camera", "camera, steady light")):
            found_at, other, total = [0, 0], [0, 0], 0
            for path in videos[family]:
                for at in edit_at[path]:
                    edit = make(at)
                    kind = "cut" if edit.kind == "restart" else "frozen"
                    edited = folder / "edited.mp4"
                    edit_video(path, edited, edit, FPS)
                    for k, found in enumerate(picture_breaks(edited)):
                        hit = [b for b in found if b.kind == kind and abs(b.frame - at) <= 1]
                        found_at[k] += bool(hit)
                        other[k] += len(found) - len(hit)
                    total += 1
            print(
                f"| {label} | {family} | {total} | {found_at[0]} | {found_at[1]} | {other[0]} | {other[1]} |",
                flush=True,
            )
    print()
    print("| round | meter (ms per 1080p frame) | the freeze's measure alone | ratio |")
    print("|---|---|---|---|")
    for k, (fed, alone) in enumerate(cost_per_frame(), 1):
        print(f"| {k} | {fed:.2f} | {alone:.2f} | {fed / alone:.1f} |")


if __name__ == "__main__":
    main()
