"""Every-mover detection throughput at 1080p against decode-only, in the same run.

    python bench/movers_throughput.py [--frames 300] [--distractors 8]

Renders a 1080p crowd video (data_fixtures.crowd: one surveillance camera,
people 90-230 px tall, walkers crossing the target, H.264) into a temporary
folder, then measures frames/s of decode-only (OpenCV VideoCapture, BGR: the
baseline), of tlsync's single-target blob tracker and of every-mover
detection with linking (trackers.tracking.detect_movers, whole pipeline:
background sampling, decoding, detection, linking), and prints them as
ratios to decode-only. The bar of issue 11: at least 0.75x.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from data_fixtures.crowd import CrowdSpec, make_crowd_scene  # noqa: E402
from trackers.tracking import detect_movers, track_video  # noqa: E402


def decode_opencv(path: Path) -> float:
    cap = cv2.VideoCapture(str(path))
    n, t = 0, time.perf_counter()
    while cap.read()[0]:
        n += 1
    cap.release()
    return n / (time.perf_counter() - t)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--distractors", type=int, default=8)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        spec = CrowdSpec(fps=(25.0,), n_frames=(args.frames,), image_size=(1920, 1080), distractors=args.distractors, crf=23)
        crowd = make_crowd_scene(spec, tmp)
        path = crowd.truth["cam0"].video
        print(f"1080p H.264 crowd video: {args.frames} frames, {args.distractors} walkers in view, made in {time.perf_counter() - t:.1f} s")
        rows = []
        base = decode_opencv(path)
        rows.append(("decode only, OpenCV BGR (baseline)", base, ""))
        t = time.perf_counter()
        track = track_video(path, kind="blob", progress=False)
        rows.append(("blob tracker, one target", args.frames / (time.perf_counter() - t), f"{len(track)} frames"))
        t = time.perf_counter()
        movers = detect_movers(path, progress=False)
        rows.append(("every mover, detection + linking", args.frames / (time.perf_counter() - t), f"{len(movers)} rows, {len(movers.tracklet_ids())} tracklets"))
        print(f"\n{'':38} {'frames/s':>9} {'x decode':>9}")
        for name, fps, note in rows:
            print(f"{name:38} {fps:>9.1f} {fps / base:>9.2f}  {note}")


if __name__ == "__main__":
    main()
