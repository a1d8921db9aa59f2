"""Every-mover detection throughput at 1080p against decode-only, in the same run.

    python bench/movers_throughput.py [--frames 300] [--distractors 8] [--repeat 3] [--video PATH]

Renders a 1080p crowd video (data_fixtures.crowd: one surveillance camera,
people up to about 330 px tall, walkers crossing the target, lighting flicker and a
20 % drop, H.264 crf 23) into a temporary folder, then measures, ``--repeat``
times in turn (so that the machine's load hits every row alike):

- the floor: decoding the luma plane alone (trackers.video.iter_frames,
  grey: the reader the track stage uses), frames/s and CPU utilisation
  (process CPU time / wall time; FFmpeg decodes in threads);
- every-mover detection with linking (trackers.tracking.detect_movers: the
  background sampled over the video, then per frame the blob detector and
  MoverLinker), as a whole and per frame (the whole minus the background
  sampling, which is a fixed cost per video: on a 10-minute video it is
  amortised, on this short one it is not);
- decode-only with OpenCV (BGR) and the single-target blob tracker
  (track_video), for reference.

Prints the median of each row's frames/s and its ratio to the floor (the bar
of issue 11: at least 0.75x), the same ratio in CPU time (frames per CPU
second against the floor's: on a loaded machine, where wall time is mostly
waiting for a core, the figure to read), the machine's load average, and
the accuracy of the detections on the target (distance from the target's
true centre to the nearest detection, over the frames where it is visible).
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from data_fixtures.crowd import CrowdSpec, make_crowd_scene  # noqa: E402
from trackers.blob import BlobParams  # noqa: E402
from trackers.tracking import MOVERS_MAX_CANDIDATES, _detector, detect_movers, track_video  # noqa: E402
from trackers.video import iter_frames  # noqa: E402


def timed(run) -> tuple[float, float, object]:
    """(wall s, CPU s of this process, result) of run()."""
    wall, cpu = time.perf_counter(), time.process_time()
    out = run()
    return time.perf_counter() - wall, time.process_time() - cpu, out


def decode_opencv(path: Path) -> int:
    cap = cv2.VideoCapture(str(path))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    return n


def target_accuracy(truth, movers) -> str:
    """Median and 90th percentile distance (px) from the target's centre to the nearest detection,
    where it is visible.
    """
    errors = []
    for f in np.flatnonzero(truth.visible):
        here = movers.frame == f
        errors.append(
            np.min(np.hypot(movers.x[here] - truth.xy[f, 0], movers.y[here] - truth.xy[f, 1])) if here.any() else np.inf
        )
    errors = np.array(errors)
    on = truth.on_target(movers.frame, np.c_[movers.x, movers.y]).sum()
    return (
        f"target visible in {len(errors)} frames; nearest detection: median {np.median(errors):.2f} px, "
        f"90th percentile {np.percentile(errors, 90):.1f} px, within 5 px in {100 * np.mean(errors <= 5):.1f} %; "
        f"{len(movers)} detections ({on} on the target), {len(movers.tracklet_ids())} tracklets"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--distractors", type=int, default=8)
    parser.add_argument("--repeat", type=int, default=3, help="measurements of each row, taken in turn")
    parser.add_argument(
        "--keep", type=Path, help="render the video into this folder and keep it (reused when it is there)"
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        truth_file = folder / "truth.pkl"
        if truth_file.exists():
            truth = pickle.loads(truth_file.read_bytes())
            print(f"1080p H.264 crowd video: {truth.video}")
        else:
            t = time.perf_counter()
            spec = CrowdSpec(
                fps=(25.0,), n_frames=(args.frames,), image_size=(1920, 1080), distractors=args.distractors, crf=23
            )
            truth = make_crowd_scene(spec, folder).truth["cam0"]
            truth_file.write_bytes(pickle.dumps(truth))
            print(
                f"1080p H.264 crowd video: {args.frames} frames, {args.distractors} walkers in view, made in "
                f"{time.perf_counter() - t:.1f} s"
            )
        path = truth.video
        n = sum(1 for _ in iter_frames(path, gray=True))
        params = BlobParams(max_candidates=MOVERS_MAX_CANDIDATES)
        rows: dict[str, list[tuple[float, float]]] = {}
        loads = []
        movers = None
        for _ in range(args.repeat):
            loads.append(os.getloadavg()[0])
            wall, cpu, _ = timed(lambda: sum(1 for _ in iter_frames(path, gray=True)))
            rows.setdefault("decode only, luma plane (floor)", []).append((wall, cpu))
            wall, cpu, movers = timed(lambda: detect_movers(path, progress=False))
            rows.setdefault("every mover, detection + linking", []).append((wall, cpu))
            fixed_wall, fixed_cpu, _ = timed(lambda: _detector(path, params))
            rows.setdefault("  background sampling (fixed, s)", []).append((fixed_wall, fixed_cpu))
            rows.setdefault("  per frame (without the sampling)", []).append((wall - fixed_wall, cpu - fixed_cpu))
            wall, cpu, _ = timed(lambda: decode_opencv(path))
            rows.setdefault("decode only, OpenCV BGR", []).append((wall, cpu))
            wall, cpu, _ = timed(lambda: track_video(path, kind="blob", progress=False))
            rows.setdefault("blob tracker, one target", []).append((wall, cpu))
        floor_runs = rows["decode only, luma plane (floor)"]
        floor = n / statistics.median(w for w, _ in floor_runs)
        floor_cpu = n / statistics.median(c for _, c in floor_runs)
        print(
            f"\n{n} frames, {args.repeat} runs of each row in turn; load average (1 min) at the runs: "
            f"{', '.join(f'{v:.1f}' for v in loads)} on {os.cpu_count()} CPUs"
        )
        print(f"\n{'':36} {'frames/s':>9} {'x floor':>8} {'CPU/wall':>9} {'x floor CPU':>12}")
        for name, runs in rows.items():
            wall = statistics.median(w for w, _ in runs)
            cpu = statistics.median(c for _, c in runs)
            usage = statistics.median(c / w for w, c in runs)
            if name.startswith("  background"):
                print(f"{name:36} {wall:>8.2f}s {'':>8} {usage:>9.2f} {cpu:>11.2f}s")
            else:
                print(f"{name:36} {n / wall:>9.1f} {n / wall / floor:>8.2f} {usage:>9.2f} {n / cpu / floor_cpu:>12.2f}")
        print("\n" + target_accuracy(truth, movers))


if __name__ == "__main__":
    main()
