"""Intrinsics from rendered checkerboard photos with known truth, and bad calibration input."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from calibration.errors import CalibrationInputError
from calibration.intrinsics import (
    calibrate_detections,
    calibrate_video,
    detect_all,
    detect_board,
    parse_pattern,
)
from data_fixtures.checkerboard import render_checkerboards
from tlsync_pipeline.cli.main import main

PATTERN = parse_pattern("9x6", 0.03)
SIZE = (800, 600)  # the conftest's rendered boards


@pytest.fixture(scope="session")
def detections(board_dir):
    files = sorted(str(p) for p in board_dir.glob("*.png"))
    return detect_all([(f, f) for f in files], PATTERN, workers=2)


def undistortion_displacement(K_true, d_true, K_est, d_est, size, model="opencv") -> float:
    """Mean |difference| (px) of the two lenses' undistortion displacement over a grid of the image."""
    w, h = size
    xs, ys = np.meshgrid(np.linspace(0, w - 1, 40), np.linspace(0, h - 1, 30))
    uv = np.column_stack([xs.ravel(), ys.ravel()]).reshape(-1, 1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)

    def shift(K, d):
        if model == "fisheye":
            und = cv2.fisheye.undistortPoints(uv, K, d, P=K)
        else:
            und = cv2.undistortPoints(uv, K, d, None, None, K, crit)
        return und.reshape(-1, 2) - uv.reshape(-1, 2)

    return float(np.linalg.norm(shift(K_true, d_true) - shift(K_est, d_est), axis=1).mean())


@pytest.mark.parametrize("model", ["standard", "rational"])
def test_recovers_the_true_camera(boards, detections, model):
    result = calibrate_detections(detections, PATTERN, model)
    K, T = result.K, boards.K
    for i, j in ((0, 0), (1, 1), (0, 2), (1, 2)):
        assert abs(K[i, j] - T[i, j]) <= 0.005 * T[i, j], (model, K, T)
    assert abs(K[0, 0] / K[1, 1] - T[0, 0] / T[1, 1]) < 0.002  # non-square pixels are kept
    assert undistortion_displacement(T, boards.dist, K, result.dist, SIZE) < 0.3
    assert result.rms < 0.5 and len(result.dist) == (8 if model == "rational" else 5)
    assert result.image_size == SIZE


def test_cut_off_and_absent_boards_are_rejected_with_a_reason(boards, detections):
    result = calibrate_detections(detections, PATTERN)
    kinds = {v.name: v.kind for v in boards.views}
    rejected = {Path(s).name: r for s, r in result.rejected.items()}
    for name, kind in kinds.items():
        if kind == "cut":
            assert rejected[name].startswith(("incomplete board", "no board")), rejected
        elif kind == "absent":
            assert rejected[name] == "no board found"
    used = {Path(s).name for s in result.used}
    assert used <= {n for n, k in kinds.items() if k == "full"}
    assert len(used) >= 13
    report = result.to_report()
    assert report["views_used"] == len(used) and len(report["per_view"]) == len(used)
    assert all(set(r) == {"image", "reason"} for r in report["rejected"])


def test_detected_corners_match_the_truth(boards):
    view, image = next((v, img) for v, img in zip(boards.views, boards.images) if v.kind == "full")
    corners, method, _ = detect_board(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), PATTERN.size)
    truth = view.corners
    err = min(
        np.abs(corners - truth).max(), np.abs(corners[::-1] - truth).max()
    )  # the detector may start at either end
    assert method == "classic" and err < 0.3  # the cheapest detector, tried first


def test_outlier_views_are_dropped(boards, detections):
    bad = list(detections)
    index = next(i for i, d in enumerate(bad) if d.corners is not None)
    moved = bad[index].corners.copy()
    moved[::7] += 4.0  # a view with badly placed corners
    bad[index] = type(bad[index])(bad[index].source, bad[index].image_size, moved, "sb", None)
    result = calibrate_detections(bad, PATTERN)
    assert result.rejected[bad[index].source].startswith("outlier")
    assert abs(result.K[0, 0] - boards.K[0, 0]) <= 0.005 * boards.K[0, 0]


def test_fisheye_model_on_a_fisheye_lens():
    K = np.array([[300.0, 0, 322.0], [0, 290.0, 236.0], [0, 0, 1]])
    D = np.array([0.05, -0.02, 0.01, -0.003])
    boards = render_checkerboards(
        seed=4, n_full=12, n_cut=0, n_absent=0, image_size=(640, 480), K=K, dist=D, dist_model="fisheye"
    )
    dets = [detect_board(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY), PATTERN.size) for img in boards.images]
    from calibration.intrinsics import Detection

    found = [Detection(v.name, (640, 480), c, m, r) for v, (c, m, r) in zip(boards.views, dets)]
    result = calibrate_detections(found, PATTERN, "fisheye")
    assert result.dist_model == "fisheye" and len(result.dist) == 4
    for i, j in ((0, 0), (1, 1), (0, 2), (1, 2)):
        assert abs(result.K[i, j] - K[i, j]) <= 0.005 * K[i, j], result.K
    # The fisheye lens's undistortion displacement grows to tens of px in the corners, so
    # check the whole lens instead: true rays of a pixel grid reprojected with the estimate.
    xs, ys = np.meshgrid(np.linspace(0, 639, 40), np.linspace(0, 479, 30))
    uv = np.column_stack([xs.ravel(), ys.ravel()]).reshape(-1, 1, 2)
    rays = cv2.fisheye.undistortPoints(uv, K, D).reshape(-1, 2)
    back = cv2.fisheye.projectPoints(
        np.column_stack([rays, np.ones(len(rays))]).reshape(-1, 1, 3),
        np.zeros((3, 1)),
        np.zeros((3, 1)),
        result.K,
        result.dist,
    )[0]
    assert np.linalg.norm(back.reshape(-1, 2) - uv.reshape(-1, 2), axis=1).mean() < 0.6
    assert result.camera("c").dist_model == "fisheye"


def test_video_skips_blurred_and_duplicate_frames(boards, tmp_path):
    path = tmp_path / "boards.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, SIZE)
    full = [img for v, img in zip(boards.views, boards.images) if v.kind == "full"][:8]
    for k, img in enumerate(full):
        writer.write(img)
        writer.write(img)  # the board held still: a duplicate
        if k == 3:
            writer.write(cv2.GaussianBlur(img, (0, 0), 6))  # waved too fast
    writer.release()
    result = calibrate_video(path, PATTERN, max_frames=100, workers=1)
    reasons = list(result.rejected.values())
    assert sum(r.startswith("duplicate") for r in reasons) >= 7
    assert sum(r.startswith("blurred") for r in reasons) == 1
    assert len(result.used) == 8 and all(s.startswith("boards.avi@") for s in result.used)
    assert abs(result.K[0, 0] - boards.K[0, 0]) <= 0.01 * boards.K[0, 0]


def test_pattern_parsing():
    assert parse_pattern("7x6", 0.025).size == (7, 6)
    for bad in ("7", "7x", "ax6", "1x6"):
        with pytest.raises(CalibrationInputError, match="COLSxROWS|at least"):
            parse_pattern(bad, 0.025)
    with pytest.raises(CalibrationInputError, match="positive length"):
        parse_pattern("7x6", 0)


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_cli_writes_an_intrinsics_only_camera_json(board_dir, tmp_path, boards):
    out = tmp_path / "cam.json"
    result = _cli(
        "calibrate-intrinsics",
        "--images",
        board_dir / "board_00*.png",
        "--pattern",
        "9x6",
        "--square",
        0.03,
        "--out",
        out,
        "--quiet",
        "--report",
        tmp_path / "r.json",
    )
    assert result.exit_code == 0, result.output
    import json

    data = json.loads(out.read_text())
    assert {"K", "dist", "image_size", "rms"} <= set(data) and not {"R", "t"} & set(data)  # the pose is to be estimated
    assert data["image_size"] == list(SIZE)
    assert "rejected" in result.output and json.loads((tmp_path / "r.json").read_text())["views_used"] >= 7


def _images(directory: Path, boards, views) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    for i, img in enumerate(views):
        cv2.imwrite(str(directory / f"img_{i:02d}.png"), img)
    return directory


@pytest.mark.parametrize(
    "make, args, message",
    [
        (
            lambda d, b: _images(
                d,
                b,
                [img for v, img in zip(b.views, b.images) if v.kind == "absent"] * 1
                + [np.full((600, 800, 3), 128, np.uint8)] * 4,
            ),
            ("--pattern", "9x6"),
            r"no 9x6 board .* in any of 5 images; rejected: 5 no board found",
        ),
        (
            lambda d, b: _images(
                d,
                b,
                [img for v, img in zip(b.views, b.images) if v.kind == "full"][:3]
                + [np.zeros((480, 640, 3), np.uint8)] * 3,
            ),
            ("--pattern", "9x6"),
            r"different sizes \(800x600: 3 .*640x480: 3",
        ),
        (
            lambda d, b: _images(d, b, [img for v, img in zip(b.views, b.images) if v.kind == "full"][:4]),
            ("--pattern", "9x6"),
            r"only 4 usable views of the 9x6 board in 4 images, at least 5 are needed",
        ),
        (
            lambda d, b: _images(d, b, [img for v, img in zip(b.views, b.images) if v.kind == "full"][:3]),
            ("--pattern", "7x6"),
            r"3 of 3 images show a 9x6 board \(inner corners, columns x rows\), not 7x6: use --pattern 9x6$",
        ),
        (
            lambda d, b: (_images(d, b, [b.images[0]]) / "broken.png").write_bytes(b"not a png") and d,
            ("--pattern", "9x6"),
            r"broken.png: cannot read the image",
        ),
        (lambda d, b: d, ("--pattern", "9x6"), r"no files match this pattern"),
        (lambda d, b: d, ("--pattern", "9-6"), r"--pattern: expected inner corners as COLSxROWS"),
    ],
    ids=["no-board", "sizes", "too-few", "pattern", "unreadable", "no-files", "bad-pattern"],
)
def test_bad_input_exits_2_with_a_clear_message(tmp_path, boards, make, args, message):
    folder = tmp_path / "imgs"
    folder.mkdir()
    make(folder, boards)
    result = _cli(
        "calibrate-intrinsics",
        "--images",
        folder / "*.png",
        *args,
        "--square",
        0.03,
        "--out",
        tmp_path / "c.json",
        "--quiet",
    )
    assert result.exit_code == 2, result.output
    assert re.search(message, result.output, re.M), result.output
    assert "Traceback" not in result.output and not (tmp_path / "c.json").exists()
    assert len(result.output.splitlines()) == 1, result.output


@pytest.mark.parametrize("screen_period", [None, 3.3], ids=["photo", "screen"])
def test_harsh_4k_views_are_detected_accurately(screen_period):
    """4K, strong blur (3 px), noise (sigma 8), a 70% light gradient; optionally a board on a screen (gamma, moire)."""
    from data_fixtures.checkerboard import default_camera, harsh_photo

    K, dist = default_camera((1920, 1080))
    boards = render_checkerboards(
        seed=21,
        n_full=2,
        n_cut=0,
        n_absent=0,
        image_size=(1920, 1080),
        K=K,
        dist=dist,
        supersample=1,
        blur_px=(0.5, 0.5),
        noise=(1, 1),
    )
    for i, (view, image) in enumerate(zip(boards.views, boards.images)):
        gray = harsh_photo(image, i, (3840, 2160), blur_px=3.0, noise=8.0, light=0.7, screen_period=screen_period)
        corners, _, reason = detect_board(gray, PATTERN.size)
        assert corners is not None, reason
        truth = (view.corners + 0.5) * 2 - 0.5  # rendered at 1080p, upscaled exactly 2x
        err = min(np.linalg.norm(corners - truth, axis=1).mean(), np.linalg.norm(corners[::-1] - truth, axis=1).mean())
        assert err < 0.5


@pytest.mark.parametrize("pattern, fill", [((7, 6), (0.15, 0.2)), ((5, 4), (0.08, 0.1))], ids=["7x6", "5x4-small"])
def test_boards_of_other_sizes_far_away_in_4k(pattern, fill):
    """Other patterns, boards covering 8-20% of a 4K frame's width (squares of 30-80 px)."""
    from data_fixtures.checkerboard import default_camera, harsh_photo

    K, dist = default_camera((1920, 1080))
    boards = render_checkerboards(
        seed=5,
        n_full=1,
        n_cut=0,
        n_absent=0,
        image_size=(1920, 1080),
        K=K,
        dist=dist,
        supersample=1,
        pattern=pattern,
        fill=fill,
        blur_px=(0.5, 0.5),
        noise=(1, 1),
    )
    gray = harsh_photo(boards.images[0], 0, (3840, 2160), blur_px=1.5, noise=5.0, light=0.5)
    corners, _, reason = detect_board(gray, pattern)
    assert corners is not None, reason
    truth = (boards.views[0].corners + 0.5) * 2 - 0.5
    assert (
        min(np.linalg.norm(corners - truth, axis=1).mean(), np.linalg.norm(corners[::-1] - truth, axis=1).mean()) < 0.5
    )


def test_a_few_images_of_another_size_are_rejected(detections):
    from calibration.intrinsics import Detection

    odd = [Detection(f"phone_{i}.jpg", (600, 800), None, None, "no board found") for i in range(2)]
    result = calibrate_detections(list(detections) + odd, PATTERN)
    assert result.rejected["phone_0.jpg"] == "different size 600x800 (the calibration uses 800x600)"


def test_a_cut_off_board_is_not_handed_to_the_full_size_classic_detector(monkeypatch):
    """720p photos: every complete board is found by the classic detector as before, and a cut-off one (where it
    takes 0.1-0.7 s to give up) only reaches it on the half-size copy, which fails fast."""
    boards = render_checkerboards(
        seed=12, n_full=2, n_cut=2, n_absent=0, image_size=(1280, 720), pattern=(7, 5), supersample=1
    )
    widths: list[int] = []
    classic = cv2.findChessboardCorners

    def counted(image, *args, **kwargs):
        widths.append(image.shape[1])
        return classic(image, *args, **kwargs)

    monkeypatch.setattr(cv2, "findChessboardCorners", counted)
    for view, image in zip(boards.views, boards.images):
        widths.clear()
        corners, method, reason = detect_board(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), (7, 5))
        if view.kind == "full":
            assert method == "classic" and widths == [640, 1280]
        else:
            assert corners is None and reason.startswith("incomplete board") and widths == [640]
