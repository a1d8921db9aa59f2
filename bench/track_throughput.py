"""Tracking throughput and memory: blob and CSRT against decode-only, in the same run.

    python bench/track_throughput.py [--frames 600] [--memory | --memory-only] [--long-frames 2400] [--accuracy-only]

1. Renders a 720p H.264 video (data_fixtures.video: textured background,
   flicker, noise, a moving target) into a temporary folder.
2. Decode-only frames/s with OpenCV (VideoCapture, BGR frames): the baseline.
   PyAV decode (BGR, grey) for reference.
3. tlsync's blob and CSRT trackers (track_video, whole pipeline: background
   sampling, decoding, tracking), and a naive full-frame CSRT loop (OpenCV's
   default CSRT on VideoCapture frames from the true initial box), as
   frames/s and as ratios to decode-only.
4. Accuracy of both trackers on the tests' scene (tests/trackers: 320x240,
   jittered times, the target leaves and re-enters three times, a pole, a
   distractor; also started from a box at frame 110) and on the 720p video:
   median position error over the frames where the target is in view,
   the share of those frames tracked, false reports (frames reported while
   the target is out of view, per cent of those frames) and the worst
   re-acquisition delay after the target re-enters (frames); with the
   tracker's CPU time as a ratio to decoding (PyAV grey) in the same run.
5. --memory: peak resident memory of tracking 1080p videos of two lengths
   (each in a fresh process), generated quickly (a few noisy backgrounds
   cycled, ultrafast x264), to show memory does not grow with length and
   extrapolate to 10 minutes (18,000 frames at 30 fps).
"""

from __future__ import annotations

import argparse
import inspect
import subprocess
import sys
import tempfile
import time
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _memory import peak_rss_mb  # noqa: E402

from data_fixtures.video import loop_positions, render_video  # noqa: E402
from trackers.tracking import track_video  # noqa: E402
from trackers.video import iter_frames  # noqa: E402


def decode_opencv(path: Path) -> float:
    cap = cv2.VideoCapture(str(path))
    n, t = 0, time.perf_counter()
    while True:
        ok, _ = cap.read()
        if not ok:
            break
        n += 1
    cap.release()
    return n / (time.perf_counter() - t)


def decode_pyav(path: Path, gray: bool) -> float:
    t = time.perf_counter()
    n = sum(1 for _ in iter_frames(path, gray=gray))
    return n / (time.perf_counter() - t)


def tracker_fps(path: Path, kind: str, n: int) -> tuple[float, int]:
    t = time.perf_counter()
    track = track_video(path, kind=kind, progress=False)
    return n / (time.perf_counter() - t), len(track)


def naive_csrt_fps(path: Path, box: tuple[int, int, int, int]) -> float:
    cap = cv2.VideoCapture(str(path))
    ok, frame = cap.read()
    tracker = cv2.TrackerCSRT.create()
    tracker.init(frame, box)
    n, t = 1, time.perf_counter()
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        tracker.update(frame)
        n += 1
    return n / (time.perf_counter() - t)


def accuracy(track, video, start: int = 0) -> tuple[float, float, float, int]:
    """From frame ``start`` on: (median error px over in-view frames, % of in-view frames tracked, % of out-of-view
    frames reported, worst re-acquisition delay in frames).
    """
    f = track.frame
    visible = video.in_view[f]
    errors = np.hypot(track.x - video.truth[f, 0], track.y - video.truth[f, 1])[visible]
    reported = set(f.tolist())
    entries = [e for e in video.entries() if e >= start]
    delays = [
        next((k - entry for k in range(entry, len(video.truth)) if k in reported), len(video.truth) - entry)
        for entry in entries
    ]
    return (
        float(np.median(errors)) if errors.size else float("nan"),
        100.0 * visible.sum() / max(1, video.in_view[start:].sum()),
        100.0 * video.out_of_view[f].sum() / max(1, video.out_of_view[start:].sum()),
        max(delays, default=0),
    )


def accuracy_table(folder: Path, video720=None) -> None:
    """Accuracy and CPU time (x decode) of both trackers on the tests' scene and on the 720p video."""
    scene = render_video(folder / "scene.mp4", jitter=0.3)
    cases = [("tests' scene", scene, {}), ("tests' scene, box at 110", scene, {"init_frame": 110})]
    if video720 is not None:
        cases.append(("720p video", video720, {}))
    print(
        f"\n{'accuracy':34} {'tracker':>7} {'median px':>9} {'in view %':>9} {'false %':>8} {'re-acq':>6} "
        f"{'CPU x decode':>12}"
    )
    for name, video, extra in cases:
        start = time.process_time()
        sum(1 for _ in iter_frames(video.path, gray=True))
        decode = time.process_time() - start
        for kind in ("blob", "csrt"):
            kwargs = dict(extra)
            if "init_frame" in kwargs:
                x, y = video.truth[kwargs["init_frame"]]
                kwargs["init"] = [x - 8, y - 8, 17, 17]
            start = time.process_time()
            track = track_video(video.path, kind=kind, progress=False, **kwargs)
            cpu = time.process_time() - start
            median, seen, false, reacq = accuracy(track, video, extra.get("init_frame", 0))
            print(f"{name:34} {kind:>7} {median:>9.3f} {seen:>9.1f} {false:>8.2f} {reacq:>6} {cpu / decode:>12.2f}")


def write_long_video(path: Path, n_frames: int, size=(1920, 1080), fps=30) -> None:
    """A fast-to-make 1080p video: four noisy textured backgrounds cycled, a bright disc moving."""
    rng = np.random.default_rng(0)
    w, h = size
    base = cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), 20)
    base = np.clip(115 + 40 * base / base.std(), 40, 190)
    backs = [
        cv2.cvtColor(np.clip(base + rng.normal(0, 2, base.shape), 0, 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)
        for _ in range(4)
    ]
    pos = loop_positions(n_frames, size, period=300)
    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=Fraction(fps))
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        stream.options = {"preset": "ultrafast", "crf": "23", "g": "60"}
        for k in range(n_frames):
            img = backs[k % 4].copy()
            x, y = pos[k]
            cv2.circle(img, (int(x), int(y)), 12, (230, 230, 230), -1, lineType=cv2.LINE_AA)
            for packet in stream.encode(av.VideoFrame.from_ndarray(img, format="bgr24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


def memory_child(path: str, kind: str) -> None:
    """Track in this process and print the peak RSS in MB."""
    track = track_video(path, kind=kind, progress=False)
    print(len(track), peak_rss_mb())


def memory(long_frames: int, folder: Path) -> None:
    print(
        f"\npeak memory, 1080p (each run in a fresh process; Python + numpy + OpenCV + PyAV loaded ~ "
        f"{_baseline_mb():.0f} MB):"
    )
    print(
        f"{'frames':>7} {'minutes@30fps':>14} {'blob MB':>8} {'csrt MB':>8} {'make s':>7} {'blob trk':>8} "
        f"{'csrt trk':>8}"
    )
    results = {}
    for n in (long_frames // 4, long_frames):
        path = folder / f"long_{n}.mp4"
        t = time.perf_counter()
        write_long_video(path, n)
        made = time.perf_counter() - t
        row = {}
        for kind in ("blob", "csrt"):
            out = subprocess.run(
                [sys.executable, __file__, "--memory-child", str(path), kind],
                capture_output=True,
                text=True,
                check=True,
            )
            tracked, row[kind] = (float(v) for v in out.stdout.split()[-2:])
            row[f"{kind} tracked"] = int(tracked)
        results[n] = row
        print(
            f"{n:>7} {n / 1800:>14.2f} {row['blob']:>8.0f} {row['csrt']:>8.0f} {made:>7.1f} {row['blob tracked']:>8} "
            f"{row['csrt tracked']:>8}"
        )
    short, long_ = results[long_frames // 4], results[long_frames]
    for kind in ("blob", "csrt"):
        slope = (long_[kind] - short[kind]) / (long_frames - long_frames // 4)
        print(
            f"{kind}: {slope * 1000:+.2f} MB per 1000 frames -> 18,000 frames (10 min): "
            f"{long_[kind] + slope * (18000 - long_frames):.0f} MB (extrapolated)"
        )


def _baseline_mb() -> float:
    code = "import av, cv2, numpy, trackers.tracking\n" + inspect.getsource(peak_rss_mb) + "print(peak_rss_mb())"
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        cwd=Path(__file__).resolve().parents[1],
    )
    return float(out.stdout.strip())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=600, help="frames of the 720p video")
    parser.add_argument("--memory", action="store_true", help="also measure peak memory on 1080p videos")
    parser.add_argument("--long-frames", type=int, default=2400, help="length of the longer 1080p video")
    parser.add_argument("--memory-only", action="store_true", help="only the memory measurement")
    parser.add_argument("--accuracy-only", action="store_true", help="only the accuracy table (tests' scene)")
    parser.add_argument("--memory-child", nargs=2, metavar=("VIDEO", "KIND"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.memory_child:
        memory_child(*args.memory_child)
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if args.memory_only:
            memory(args.long_frames, folder)
            return
        if args.accuracy_only:
            accuracy_table(folder)
            return
        t = time.perf_counter()
        size = (1280, 720)
        video = render_video(
            folder / "bench720.mp4",
            n_frames=args.frames,
            image_size=size,
            fps=30.0,
            radius=10.0,
            positions=loop_positions(args.frames, size, period=400.0),
            noise=3.0,
        )
        print(f"720p H.264 video: {args.frames} frames, made in {time.perf_counter() - t:.1f} s")
        base = decode_opencv(video.path)
        rows = [("decode only, OpenCV BGR (baseline)", base, None)]
        rows.append(("decode only, PyAV BGR", decode_pyav(video.path, False), None))
        rows.append(("decode only, PyAV grey", decode_pyav(video.path, True), None))
        for kind in ("blob", "csrt"):
            fps, n = tracker_fps(video.path, kind, args.frames)
            rows.append((f"tlsync {kind} tracker", fps, n))
        x, y = video.truth[0]
        rows.append(
            (
                "naive full-frame CSRT (OpenCV defaults)",
                naive_csrt_fps(video.path, (int(x - 14), int(y - 14), 29, 29)),
                None,
            )
        )
        print(f"\n{'':42} {'frames/s':>9} {'x decode':>9} {'tracked':>8}")
        for name, fps, n in rows:
            print(f"{name:42} {fps:>9.1f} {fps / base:>9.2f} {'' if n is None else n:>8}")
        accuracy_table(folder, video)
        if args.memory:
            memory(args.long_frames, folder)


if __name__ == "__main__":
    main()
