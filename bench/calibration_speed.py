"""Checkerboard detection and calibration speed (not a test).

Prints per-image corner detection time at 1080p and 4K on one core (board
present, and the failure path with no board), JPEG decoding time, and the
end-to-end time to calibrate from a folder of 100 1080p JPEGs on all cores.
Times are also given as ratios to a fixed numpy workload (sorting 1e7 floats)
measured in the same run. Goals: <= 50 ms per 4K image, < 15 s for 100 images.

    python bench/calibration_speed.py [--images 100] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from calibration.intrinsics import calibrate_images, detect_board, parse_pattern  # noqa: E402
from data_fixtures.checkerboard import default_camera, render_checkerboards  # noqa: E402

PATTERN = parse_pattern("9x6", 0.03)


def baseline() -> float:
    data = np.random.default_rng(0).random(10_000_000)
    start = time.perf_counter()
    np.sort(data)
    return time.perf_counter() - start


def render(size, n_full, n_absent, seed):
    K, dist = default_camera(size)
    return render_checkerboards(
        seed=seed,
        n_full=n_full,
        n_cut=0,
        n_absent=n_absent,
        image_size=size,
        K=K,
        dist=dist,
        supersample=1,
        blur_px=(0.6, 1.2),
    )


def upscale(image, size):
    return cv2.resize(image, size, interpolation=cv2.INTER_CUBIC)


def per_image(grays, repeat) -> tuple[float, int]:
    """Median single-core detection time (s) over images x repeats, and how many boards were found."""
    times, found = [], 0
    for gray in grays:
        for _ in range(repeat):
            start = time.perf_counter()
            corners, _, _ = detect_board(gray, PATTERN.size)
            times.append(time.perf_counter() - start)
        found += corners is not None
    return float(np.median(times)), found


def decode_time(image) -> float:
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 92])
    start = time.perf_counter()
    for _ in range(3):
        cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)
    return (time.perf_counter() - start) / 3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    base = baseline()
    print(f"baseline (sort 1e7 floats): {base * 1000:.0f} ms; cores: {os.cpu_count()}")

    hd = render((1920, 1080), 4, 1, seed=10)
    cv2.setNumThreads(1)
    rows = []
    for label, size in (("1080p", (1920, 1080)), ("4K", (3840, 2160))):
        images = [img if size == (1920, 1080) else upscale(img, size) for img in hd.images]
        grays = [cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) for img in images]
        kinds = [v.kind for v in hd.views]
        with_board = [g for g, k in zip(grays, kinds) if k == "full"]
        without = [g for g, k in zip(grays, kinds) if k == "absent"]
        t_board, found = per_image(with_board, args.repeat)
        t_none, _ = per_image(without, args.repeat)
        t_decode = decode_time(images[0])
        rows.append((label, t_board, found, len(with_board), t_none, t_decode))
    cv2.setNumThreads(0)
    print("\n| image | detect, board (ms) | x baseline | found | detect, no board (ms) | JPEG decode (ms) |")
    print("|---|---:|---:|---:|---:|---:|")
    for label, t_board, found, n, t_none, t_decode in rows:
        print(
            f"| {label} | {t_board * 1000:.0f} | {t_board / base:.2f} | {found}/{n} | {t_none * 1000:.0f} | "
            f"{t_decode * 1000:.0f} |"
        )

    # A folder of 1080p JPEGs: 20 rendered views, each also shifted by a few pixels (distinct views).
    views = render((1920, 1080), 20, 0, seed=11)
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as folder:
        for i in range(args.images):
            img = views.images[i % len(views.images)]
            if i >= len(views.images):
                shift = np.float32([[1, 0, rng.uniform(-40, 40)], [0, 1, rng.uniform(-40, 40)]])
                img = cv2.warpAffine(img, shift, (1920, 1080), borderMode=cv2.BORDER_REPLICATE)
            cv2.imwrite(os.path.join(folder, f"img_{i:03d}.jpg"), img, [cv2.IMWRITE_JPEG_QUALITY, 92])
        start = time.perf_counter()
        result = calibrate_images(os.path.join(folder, "*.jpg"), PATTERN)
        total = time.perf_counter() - start
    print(
        f"\n{args.images} images at 1080p on {os.cpu_count()} cores, read + detect + calibrate: {total:.1f} s "
        f"({total / base:.0f} x baseline); "
        f"{len(result.used)} used, {len(result.rejected)} rejected "
        f"({dict(Counter(r.split(' (')[0].split(':')[0] for r in result.rejected.values()))}), RMS {result.rms:.3f} px"
    )


if __name__ == "__main__":
    main()
