"""Camera pose from ground control points and from a board at a known pose."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from calibration.errors import CalibrationInputError
from calibration.extrinsics import pose_from_board, pose_from_points, read_gcps
from calibration.intrinsics import detect_board, parse_pattern
from data_fixtures.checkerboard import default_camera, render_checkerboards
from data_fixtures.gcp import looking_at, make_gcps, write_gcp_csv

SIZE = (960, 720)
K, DIST = default_camera(SIZE)
R_TRUE, T_TRUE = looking_at((2.0, -14.0, 7.0), (0.0, 8.0, 0.0))


def angle_deg(Ra, Rb) -> float:
    return float(np.degrees(np.linalg.norm(cv2.Rodrigues(Ra @ Rb.T)[0])))


def centre(R, t):
    return -R.T @ t


def test_six_noise_free_points_give_the_pose():
    uv, xyz, _ = make_gcps(K, DIST, R_TRUE, T_TRUE, SIZE, n=6, seed=3)
    pose = pose_from_points(uv, xyz, K, DIST)
    assert angle_deg(pose.R, R_TRUE) < 0.05
    assert np.linalg.norm(pose.center - centre(R_TRUE, T_TRUE)) < 0.01
    assert pose.inliers.all() and pose.rms < 0.01 and "RANSAC" in pose.method


def test_four_points_are_enough():
    uv, xyz, _ = make_gcps(K, DIST, R_TRUE, T_TRUE, SIZE, n=4, seed=5)
    pose = pose_from_points(uv, xyz, K, DIST)
    assert angle_deg(pose.R, R_TRUE) < 0.05 and np.linalg.norm(pose.center - centre(R_TRUE, T_TRUE)) < 0.01


def test_noisy_points_stay_within_the_predicted_spread():
    """8 GCPs with 1 px noise: over many draws, the pose error matches the reported uncertainty."""
    _, xyz, uv_true = make_gcps(K, DIST, R_TRUE, T_TRUE, SIZE, n=8, seed=7)
    rng = np.random.default_rng(0)
    rot_err, pos_err, rot_std, pos_std, rms = [], [], [], [], []
    for _ in range(40):
        pose = pose_from_points(uv_true + rng.normal(0, 1.0, uv_true.shape), xyz, K, DIST)
        rot_err.append(angle_deg(pose.R, R_TRUE))
        pos_err.append(np.linalg.norm(pose.center - centre(R_TRUE, T_TRUE)))
        rot_std.append(pose.rotation_std_deg)
        pos_std.append(pose.position_std_m)
        rms.append(pose.rms)
    assert 0.6 < np.mean(rms) < 1.4  # the reported error reflects the 1 px noise
    for err, std in ((rot_err, rot_std), (pos_err, pos_std)):
        ratio = np.sqrt(np.mean(np.square(err))) / np.mean(std)
        assert 0.5 < ratio < 1.6, ratio
        assert np.max(np.array(err) / np.array(std)) < 4.5


def test_ransac_flags_a_wrong_point():
    uv, xyz, _ = make_gcps(K, DIST, R_TRUE, T_TRUE, SIZE, n=8, seed=11)
    uv[2] += [60.0, -40.0]  # clicked on the wrong post
    pose = pose_from_points(uv, xyz, K, DIST)
    assert not pose.inliers[2] and pose.inliers.sum() == 7
    assert pose.errors[2] > 30 and angle_deg(pose.R, R_TRUE) < 0.05


def test_six_points_on_the_ground_clicked_to_a_pixel_give_the_pose():
    """A surveillance camera 5 m up, its six GCPs on the ground clicked to about a pixel, their heights the micrometres
    a geodetic conversion leaves: RANSAC's SQPnP samples find no pose within 8 px on these; the pose is still found,
    every point an inlier."""
    K_low = np.array([[403.2, 0.0, 239.5906204225149], [0.0, 403.2, 183.30994964566165], [0.0, 0.0, 1.0]])
    dist = np.array([-0.07514983856626387, 0.0, 0.0, 0.0, 0.0])
    xyz = np.array(
        [
            [3.8377332628541883, 8.7433723889358603, -7.15e-06],
            [5.7447071339310671, 6.8090489226526030, -6.22e-06],
            [10.327588109947607, 2.4212500366031819, -8.80e-06],
            [1.7719114422305962, 6.6789797782131499, -3.75e-06],
            [5.5705113704273508, 4.0431863918449507, -3.71e-06],
            [5.8981899436512881, 2.5702093619437294, -3.24e-06],
        ]
    )
    uv = np.array(
        [[96.78, 223.11], [201.53, 223.94], [442.28, 215.06], [48.22, 298.55], [283.53, 271.74], [355.85, 294.52]]
    )
    pose = pose_from_points(uv, xyz, K_low, dist, ransac_px=8.0)
    assert pose.inliers.all() and pose.rms < 2.0
    assert np.linalg.norm(pose.center - [0.0, 0.0, 5.0]) < 0.2


@pytest.mark.parametrize(
    "uv, xyz, message",
    [
        (np.zeros((3, 2)), np.zeros((3, 3)), "3 points, at least 4 are needed"),
        (
            np.array([[10, 10], [200, 50], [300, 400], [500, 90]], float),
            np.array([[0, 0, 0], [1, 1, 0], [2, 2, 0], [3, 3, 0]], float),
            "world points are collinear",
        ),
        (
            np.array([[10, 10], [20, 20], [30, 30], [40, 40], [50, 50]], float),
            np.array([[0, 0, 0], [1, 3, 0], [2, 1, 0], [3, 5, 1], [0, 4, 2]], float),
            "pixel positions are collinear",
        ),
    ],
)
def test_degenerate_points_are_refused(uv, xyz, message):
    with pytest.raises(CalibrationInputError, match=message):
        pose_from_points(uv, xyz, K, DIST, source="g.csv")


def test_gcp_csv_reader(tmp_path):
    uv, xyz, _ = make_gcps(K, DIST, R_TRUE, T_TRUE, SIZE, n=5, seed=1)
    table = read_gcps(write_gcp_csv(tmp_path / "g.csv", uv, xyz))
    assert (
        np.allclose(table.uv, uv) and np.allclose(table.xyz, xyz) and table.geodetic is None and table.names[0] == "p0"
    )
    geo = read_gcps(
        write_gcp_csv(tmp_path / "h.csv", uv, np.column_stack([xyz[:, :2] * 1e-5 + [47, 8], xyz[:, 2]]), geodetic=True)
    )
    assert geo.xyz is None and geo.geodetic.shape == (5, 3)


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "u,v,x,y,lat,lon\n1,2,3,4,5,6\n",
            r"g.csv:1: the header mixes local columns \(x,y\) and geodetic columns \(lat,lon\)",
        ),
        ("u,v,x,y\n1,2,3,4\n", r"g.csv:1: missing column\(s\) z"),
        ("# surveyed 2024\nu,v,x,y,z\n1,2,3,4,5\n1,2,three,4,5\n", r"g.csv:4: column 'x': not a number: 'three'"),
        ("u,v,x,y,z\n1,2,3,4\n", r"g.csv:2: expected 5 values"),
        ("u,v,lat,lon,alt\n1,2,147,8,400\n", r"g.csv:2: lat/lon out of range"),
        ("", r"g.csv: empty file"),
    ],
)
def test_bad_gcp_files(tmp_path, text, message):
    (tmp_path / "g.csv").write_text(text)
    with pytest.raises(CalibrationInputError, match=message):
        read_gcps(tmp_path / "g.csv")


def test_pose_from_a_board_at_a_known_world_pose():
    pattern = parse_pattern("9x6", 0.03)
    boards = render_checkerboards(seed=2, n_full=2, n_cut=0, n_absent=0, image_size=(800, 600))
    # The board lies somewhere in the world: world = Rb @ board + tb.
    Rb = cv2.Rodrigues(np.array([0.3, -0.2, 1.1]))[0]
    tb = np.array([4.0, -2.0, 0.5])
    for view, image in zip(boards.views, boards.images):
        gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        corners, _, _ = detect_board(gray, pattern.size)
        pose = pose_from_board(gray, corners, pattern, Rb, tb, boards.K, boards.dist)
        R_cb = cv2.Rodrigues(view.rvec)[0]  # board -> camera
        R_true = R_cb @ Rb.T
        t_true = view.tvec - R_true @ tb
        assert angle_deg(pose.R, R_true) < 0.1
        assert np.linalg.norm(pose.center - centre(R_true, t_true)) < 0.002


def test_board_pose_needs_an_unambiguous_pattern():
    with pytest.raises(CalibrationInputError, match="180 degrees"):
        pose_from_board(
            np.zeros((10, 10), np.uint8), np.zeros((35, 2)), parse_pattern("7x5", 0.03), np.eye(3), np.zeros(3), K, DIST
        )
