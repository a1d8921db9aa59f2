"""Cost of the report's proxy clips: transcoding against decoding the same video, in the same run.

    python bench/proxy_speed.py [--frames 600]

1. Writes a 720p MPEG-4 part 2 video (a format browsers cannot play; OpenCV's
   mp4v writer) of a moving disc over noise, 30 fps.
2. Decode-only (trackers.video.iter_frames, BGR): the baseline, frames/s.
3. make_proxy (decode, scale to 360 p, H.264 veryfast CRF 28): frames/s, the
   ratio to decode-only, and the proxy's size against the source's.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tlsync_pipeline.outputs.proxy import make_proxy  # noqa: E402
from trackers.video import iter_frames  # noqa: E402


def write_source(path: Path, n_frames: int, size=(1280, 720), fps: float = 30.0) -> None:
    rng = np.random.default_rng(0)
    background = rng.integers(40, 200, (size[1], size[0], 3), dtype=np.uint8)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    for k in range(n_frames):
        image = background.copy()
        cv2.circle(image, (int(100 + 3 * k) % size[0], 360), 12, (255, 255, 255), -1)
        writer.write(image)
    writer.release()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        source, proxy = Path(folder) / "source.mp4", Path(folder) / "proxy.mp4"
        write_source(source, args.frames)
        start = time.perf_counter()
        n = sum(1 for _ in iter_frames(source))
        decode = n / (time.perf_counter() - start)
        start = time.perf_counter()
        make_proxy(source, proxy)
        transcode = n / (time.perf_counter() - start)
        print(f"{n} frames of 1280x720 MPEG-4 part 2")
        print(f"decode only       {decode:7.1f} frames/s  1.00x")
        print(f"proxy (360p H.264) {transcode:6.1f} frames/s  {transcode / decode:.2f}x of decode-only")
        print(f"proxy size: {proxy.stat().st_size / 1e6:.2f} MB for a {source.stat().st_size / 1e6:.2f} MB source")


if __name__ == "__main__":
    main()
