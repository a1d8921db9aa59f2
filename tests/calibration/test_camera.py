import json

import cv2
import numpy as np
import pytest

from calibration.camera import Camera, PoseInfo, read_camera, write_camera
from calibration.errors import CalibrationInputError
from calibration.lens import distort_normalized


def _camera(dist=(0.1, -0.05, 0.001, -0.002, 0.01)):
    R = cv2.Rodrigues(np.array([0.1, -0.2, 0.05]))[0]
    K = np.array([[800.0, 0.0, 320.0], [0.0, 790.0, 240.0], [0.0, 0.0, 1.0]])
    return Camera("c", K, np.array(dist), R, np.array([0.2, -0.1, 5.0]), (640, 480), 30.0)


def test_projection_matches_opencv():
    cam = _camera()
    pts = np.random.default_rng(1).uniform(-1, 1, (50, 3))
    uv, valid = cam.project(pts)
    ref, _ = cv2.projectPoints(pts, cam.rvec, cam.t, cam.K, cam.dist)
    assert valid.all()
    np.testing.assert_allclose(uv, ref.reshape(-1, 2), atol=1e-9)


def test_points_behind_or_far_outside_are_dropped():
    cam = _camera(dist=(0, 0, 0, 0, 0))
    behind = cam.R.T @ (np.array([0, 0, -1.0]) - cam.t)
    far_side = cam.R.T @ (np.array([100.0, 0, 1.0]) - cam.t)
    ahead = cam.R.T @ (np.array([0.0, 0, 3.0]) - cam.t)
    uv, valid = cam.project(np.array([behind, far_side, ahead]))
    assert valid.tolist() == [False, False, True]
    assert np.isnan(uv[0]).all()
    np.testing.assert_allclose(uv[2], [320.0, 240.0], atol=1e-9)


def test_json_round_trip_and_alternative_forms(tmp_path):
    cam = _camera()
    write_camera(cam, tmp_path / "camera.json")
    back = read_camera(tmp_path / "camera.json")
    np.testing.assert_allclose(back.R, cam.R, atol=1e-12)
    np.testing.assert_allclose(back.K, cam.K)
    assert back.fps == 30.0 and back.image_size == (640, 480)

    as_rvec = Camera.from_dict(
        {
            "K": cam.K.tolist(),
            "dist": cam.dist.tolist(),
            "rvec": cam.rvec.tolist(),
            "tvec": cam.t.tolist(),
            "image_size": [640, 480],
        }
    )
    np.testing.assert_allclose(as_rvec.R, cam.R, atol=1e-12)

    P = cam.K @ np.column_stack([cam.R, cam.t]) * 3.7  # any scale
    as_p = Camera.from_dict({"P": P.tolist(), "image_size": [640, 480]})
    np.testing.assert_allclose(as_p.K, cam.K, atol=1e-6)
    np.testing.assert_allclose(as_p.R, cam.R, atol=1e-9)
    np.testing.assert_allclose(as_p.t, cam.t, atol=1e-9)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"K": [[800, 0, 320], [0, 790, 240]]}, "field 'K': expected shape 3x3"),
        ({"K": [800, 0, 320, 0, 790, 240, 0, 0, 1]}, "flat list"),
        ({"K": [[0, 0, 320], [0, 0, 240], [0, 0, 1]]}, "singular"),
        ({"R": [[1, 0, 0], [0, 1, 0], [0, 0, float("nan")]]}, "NaN"),
        ({"R": [[1, 0, 0], [0, 2, 0], [0, 0, 1]]}, "not a rotation"),
        ({"t": [1, 2]}, "field 't'"),
        ({"dist": [0.1, 0.2, 0.3]}, "field 'dist'"),
        ({"image_size": [640]}, "field 'image_size'"),
        ({"K": "eye"}, "field 'K'"),
    ],
)
def test_bad_fields_name_the_file_and_field(tmp_path, change, message):
    data = _camera().to_dict()
    data.update(change)
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(data))
    with pytest.raises(CalibrationInputError, match=message) as info:
        read_camera(path)
    assert str(path) in str(info.value)


def test_missing_and_invalid_json(tmp_path):
    with pytest.raises(CalibrationInputError, match="file not found"):
        read_camera(tmp_path / "nope.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"K": [1, 2,\n')
    with pytest.raises(CalibrationInputError, match=r"bad.json:\d+: invalid JSON"):
        read_camera(bad)


def test_a_camera_json_without_a_pose_is_a_pose_to_estimate(tmp_path):
    cam = _camera()
    data = {"K": cam.K.tolist(), "dist": cam.dist.tolist(), "image_size": [640, 480], "fps": 25}
    (tmp_path / "c.json").write_text(json.dumps(data))
    back = read_camera(tmp_path / "c.json")
    assert not back.posed and back.to_estimate == ("pose",)
    np.testing.assert_allclose(back.K, cam.K)
    with pytest.raises(ValueError, match="pose is still to be estimated"):
        back.project(np.zeros((1, 3)))
    write_camera(back, tmp_path / "again.json")
    again = json.loads((tmp_path / "again.json").read_text())
    assert "R" not in again and "t" not in again and again["K"] == data["K"]  # written back without a pose
    with pytest.raises(CalibrationInputError, match="missing field 't'"):  # half a pose is still an error
        Camera.from_dict({**data, "R": np.eye(3).tolist()})


def test_a_camera_json_with_the_image_size_only_has_its_intrinsics_to_estimate():
    back = Camera.from_dict({"image_size": [640, 480]})
    assert back.to_estimate == ("pose", "intrinsics")
    assert back.K[0, 0] == 640 and back.K[0, 2] == pytest.approx(319.5)  # a guess: about 53 degrees across, centred
    assert "K" not in back.to_dict() and "R" not in back.to_dict()
    with pytest.raises(CalibrationInputError, match="missing field 'K'"):  # with a pose, K is required
        Camera.from_dict({"image_size": [640, 480], "R": np.eye(3).tolist(), "t": [0, 0, 0]})


def test_the_pose_source_and_uncertainty_round_trip(tmp_path):
    cam = _camera()
    posed = Camera(
        cam.name,
        cam.K,
        cam.dist,
        cam.R,
        cam.t,
        cam.image_size,
        cam.fps,
        pose_info=PoseInfo("gcp+target", 0.03, 0.05, False, "good for timing, not for 3D"),
    )
    write_camera(posed, tmp_path / "c.json")
    data = json.loads((tmp_path / "c.json").read_text())
    assert data["pose"] == {
        "source": "gcp+target",
        "center_std_m": 0.03,
        "rotation_std_deg": 0.05,
        "for_3d": False,
        "note": "good for timing, not for 3D",
    }
    assert read_camera(tmp_path / "c.json").pose_info == posed.pose_info
    assert read_camera(tmp_path / "c.json").posed
    data["pose"] = {"source": "guess"}
    with pytest.raises(CalibrationInputError, match="field 'pose'"):
        Camera.from_dict(data)


@pytest.mark.parametrize(
    "image_size, cropped, refused",
    [
        ([320, 240], False, True),  # K of a 640 x 480 image, image_size of its half: off by 2 on both axes
        ([8000, 6000], False, True),  # ... of a much larger one: off by 0.08
        ([320, 480], False, False),  # the left half of the image, cropped: cx at its right edge, cy at the centre
        ([640, 240], False, False),  # the top half
        ([320, 240], True, False),  # the top-left quarter, cropped: the resolution's signature, declared
    ],
)
def test_a_cropped_camera_is_told_from_an_image_size_of_another_resolution(tmp_path, image_size, cropped, refused):
    data = _camera().to_dict()  # K of a 640 x 480 image, principal point at its centre
    data["K"] = [[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]]
    data["image_size"] = image_size
    if cropped:
        data["cropped"] = True
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(data))
    if refused:
        with pytest.raises(
            CalibrationInputError,
            match=r"on both axes: K and image_size are of different resolutions .*\"cropped\": true",
        ):
            read_camera(path)
    else:
        camera = read_camera(path)
        assert camera.image_size == tuple(image_size)
        write_camera(camera, tmp_path / "again.json")
        assert read_camera(tmp_path / "again.json").image_size == tuple(image_size)  # "cropped" kept


@pytest.mark.parametrize("count", [0, 4, 5, 8, 12, 14])
def test_distortion_gives_opencvs_very_pixels(count):
    """The polynomial lens model evaluated in NumPy gives projectPoints' numbers bit for bit (any coefficient count;
    a tilted sensor goes through OpenCV)."""
    rng = np.random.default_rng(count)
    normalized = rng.uniform(-0.8, 0.8, (5000, 2))
    K = np.array([[1000.3, 0.0, 640.2], [0.0, 1001.1, 360.7], [0.0, 0.0, 1.0]])
    dist = rng.normal(0.0, 0.02, count)
    rays = np.column_stack([normalized, np.ones(len(normalized))]).reshape(-1, 1, 3)
    expected = cv2.projectPoints(rays, np.zeros((3, 1)), np.zeros((3, 1)), K, dist if count else None)[0]
    assert np.array_equal(distort_normalized(normalized, K, dist, "opencv"), expected.reshape(-1, 2))


@pytest.mark.parametrize("count", [0, 4, 5, 8, 12])
def test_the_pixels_derivative_in_the_world_points_is_the_projections_own(count):
    """Camera.point_jacobian against central differences of ``project``, for every polynomial lens model."""
    rng = np.random.default_rng(count)
    dist = rng.normal(0.0, [0.2, 0.05, 0.002, 0.002, 0.01, 0.1, 0.02, 0.005, 0.002, 0.001, 0.002, 0.001])[:count]
    K = np.array([[1500.0, 0.0, 960.0], [0.0, 1480.0, 540.0], [0.0, 0.0, 1.0]])
    R = cv2.Rodrigues(rng.normal(0.0, 1.0, 3))[0]
    camera = Camera("c", K, dist, R, np.array([1.0, 2.0, 30.0]), (1920, 1080))
    seen = np.column_stack([rng.uniform(-8, 8, 40), rng.uniform(-5, 5, 40), rng.uniform(20, 40, 40)])
    points = (seen - camera.t) @ R  # world points at those camera-frame positions
    step = 1e-6
    differences = np.stack(
        [(camera.project(points + step * e)[0] - camera.project(points - step * e)[0]) / (2 * step) for e in np.eye(3)],
        axis=2,
    )
    jacobian = camera.point_jacobian(points)
    assert jacobian is not None
    np.testing.assert_allclose(jacobian, differences, rtol=1e-6, atol=1e-6 * np.abs(differences).max())


def test_a_lens_without_an_analytic_derivative_has_none():
    K = np.array([[800.0, 0.0, 640.0], [0.0, 800.0, 360.0], [0.0, 0.0, 1.0]])
    camera = Camera("c", K, np.zeros(4), np.eye(3), np.zeros(3), (1280, 720), dist_model="fisheye")
    assert camera.point_jacobian(np.array([[0.0, 0.0, 10.0]])) is None


def test_a_lens_without_an_analytic_derivative_gets_the_projections_forward_differences():
    """Camera.pixels_per_metre falls back to finite differences of ``project`` (fisheye): at 1 mm steps, close to
    its central differences at 1 um."""
    K = np.array([[800.0, 0.0, 640.0], [0.0, 800.0, 360.0], [0.0, 0.0, 1.0]])
    camera = Camera(
        "c", K, np.array([0.05, -0.01, 0.0, 0.0]), np.eye(3), np.zeros(3), (1280, 720), dist_model="fisheye"
    )
    points = np.array([[0.0, 0.1, 10.0], [2.0, -1.0, 15.0], [-4.0, 3.0, 12.0]])
    step = 1e-6
    differences = np.stack(
        [(camera.project(points + step * e)[0] - camera.project(points - step * e)[0]) / (2 * step) for e in np.eye(3)],
        axis=2,
    )
    found = camera.pixels_per_metre(points, camera.project(points)[0])
    np.testing.assert_allclose(found, differences, rtol=1e-3, atol=1e-3 * np.abs(differences).max())
