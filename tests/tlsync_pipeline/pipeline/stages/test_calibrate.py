"""The calibrate stage through the project file and `tlsync calibrate`."""

from __future__ import annotations

import json
import re
import shutil

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from calibration.camera import Camera, read_camera, write_camera
from data_fixtures.gcp import looking_at, make_gcps, write_gcp_csv
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.geodesy import Origin, enu_to_geodetic, geodetic_to_enu
from tlsync_pipeline.pipeline.origin import project_origin
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.pipeline.stages.calibrate import calibrate_params, calibrate_pose, known_intrinsics

ORIGIN = Origin(46.52, 6.57, 420.0)


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def angle_deg(Ra, Rb) -> float:
    return float(np.degrees(np.linalg.norm(cv2.Rodrigues(Ra @ Rb.T)[0])))


def calibrate_camera(proj, name):
    """A camera's pose from its known intrinsics and GCPs, as the calibrate stage computes it (no files written)."""
    cal = proj.camera(name).calibration
    known = read_camera(cal.intrinsics)
    camera, report, _ = calibrate_pose(
        name,
        calibrate_params(proj, name, Options()),
        known,
        known_intrinsics(cal.intrinsics),
        project_origin(proj),
        cal.gcp,
        None,
    )
    return camera, report


@pytest.fixture
def project(tmp_path, boards, board_dir):
    """Two cameras: cam0 calibrated from board photos + local GCPs, cam1 from a known camera.json + geodetic GCPs; the
    GCPs exact (their pose alone).
    """
    shutil.copytree(board_dir, tmp_path / "boards")
    truth = {}
    for name, center, seed in (("cam0", (3.0, -15.0, 6.0), 1), ("cam1", (-8.0, 20.0, 9.0), 2)):
        R, t = looking_at(center, (0.0, 5.0, 0.0))
        uv, xyz, _ = make_gcps(boards.K, boards.dist, R, t, boards.image_size, n=8, seed=seed)
        if name == "cam0":
            write_gcp_csv(tmp_path / "gcp_cam0.csv", uv, xyz)
        else:
            write_gcp_csv(tmp_path / "gcp_cam1.csv", uv, enu_to_geodetic(xyz, ORIGIN), geodetic=True)
            write_gcp_csv(tmp_path / "gcp_cam1_local.csv", uv, xyz)
        truth[name] = (R, t)
    write_camera(
        Camera("known", boards.K, boards.dist, np.eye(3), np.zeros(3), boards.image_size), tmp_path / "known.json"
    )
    (tmp_path / "project.toml").write_text(
        f"""
[target]
trajectory = "trajectory.csv"
origin = [{ORIGIN.lat}, {ORIGIN.lon}, {ORIGIN.alt}]

[calibration]
gcp_sigma_m = 0

[[cameras]]
name = "cam0"
[cameras.calibration]
images = "boards/board_00*.png"
pattern = "9x6"
square = 0.03
gcp = "gcp_cam0.csv"

[[cameras]]
name = "cam1"
fps = 25
[cameras.calibration]
intrinsics = "known.json"
gcp = "gcp_cam1.csv"
"""
    )
    return tmp_path, truth


def test_calibrate_writes_every_artefact(project, boards):
    root, truth = project
    result = _cli("calibrate", root / "project.toml", "--quiet")
    assert result.exit_code == 0, result.output
    assert "cam0: " in result.output and "cam1: " in result.output
    for name in ("cam0", "cam1"):
        folder = root / "work" / "cameras" / name
        camera = read_camera(folder / "camera.json")
        R, t = truth[name]
        assert angle_deg(camera.R, R) < 0.1
        assert np.linalg.norm(camera.center - (-R.T @ t)) < 0.05
        report = json.loads((folder / "calibration_report.json").read_text())
        assert len(report["pose"]["points"]) == 8 and report["pose"]["rms_px"] < 0.5
        assert (folder / "calibration.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    cam0 = json.loads((root / "work" / "cameras" / "cam0" / "camera.json").read_text())
    assert cam0["rms"] < 0.5 and abs(cam0["K"][0][0] - boards.K[0, 0]) < 0.005 * boards.K[0, 0]
    report = json.loads((root / "work" / "cameras" / "cam0" / "calibration_report.json").read_text())
    assert report["intrinsics"]["views_used"] >= 7
    assert {v["image"] for v in report["intrinsics"]["per_view"]} | {
        r["image"] for r in report["intrinsics"]["rejected"]
    } == {
        p.relative_to(root).as_posix() for p in (root / "boards").glob("board_00*.png")
    }  # relative to the project folder
    assert read_camera(root / "work" / "cameras" / "cam1" / "camera.json").fps == 25


def test_geodetic_and_local_gcps_give_the_same_pose(project):
    root, _ = project
    proj = load_project(root / "project.toml")
    geo_cam, geo_report = calibrate_camera(proj, "cam1")
    text = (root / "project.toml").read_text().replace('gcp = "gcp_cam1.csv"', 'gcp = "gcp_cam1_local.csv"')
    (root / "local.toml").write_text(text)
    local = load_project(root / "local.toml")
    local_cam, _ = calibrate_camera(local, "cam1")
    assert angle_deg(geo_cam.R, local_cam.R) < 1e-4
    assert np.linalg.norm(geo_cam.t - local_cam.t) < 1e-3
    assert geo_report["pose"]["origin"] == {"lat": ORIGIN.lat, "lon": ORIGIN.lon, "alt": ORIGIN.alt}


def test_without_an_origin_the_geodetic_gcps_centroid_is_used(project):
    root, _ = project
    text = re.sub(r"origin = .*\n", "", (root / "project.toml").read_text())
    (root / "project.toml").write_text(text)
    proj = load_project(root / "project.toml")
    lat, lon, alt = (
        np.genfromtxt(root / "gcp_cam1.csv", delimiter=",", names=True, usecols=(3, 4, 5)).view((float, 3)).mean(axis=0)
    )
    origin = project_origin(proj)
    assert origin == pytest.approx(Origin(lat, lon, alt))
    cam, report = calibrate_camera(proj, "cam1")
    explicit = json.loads(json.dumps(report))["pose"]["origin"]
    assert explicit["lat"] == pytest.approx(lat)
    # Same camera, frame shifted by the origin's offset.
    shift = geodetic_to_enu([origin.lat], [origin.lon], [origin.alt], ORIGIN)[0]
    R_local, t_local = looking_at((-8.0, 20.0, 9.0), (0.0, 5.0, 0.0))
    assert np.linalg.norm(cam.center - ((-R_local.T @ t_local) - shift)) < 0.01


def _edit(root, old, new):
    path = root / "project.toml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


@pytest.mark.parametrize(
    "damage, message",
    [
        (
            lambda r: (r / "gcp_cam1.csv").write_text(
                "u,v,lat,lon,alt\n1,2,46.5,6.5,400\n2,3,46.5001,6.5,400\n4,4,46.5,6.5001,401\n"
            ),
            r"gcp_cam1.csv: 3 points, at least 4 are needed",
        ),
        (
            lambda r: (r / "gcp_cam1.csv").write_text(
                "u,v,x,y,z\n10,20,0,0,0\n200,40,1,1,0\n300,300,2,2,0\n400,100,3,3,0\n"
            ),
            r"gcp_cam1.csv: the world points are collinear",
        ),
        (
            lambda r: (r / "gcp_cam1.csv").write_text("name,u,v,x,y,z,lat\np,1,2,3,4,5,6\n"),
            r"gcp_cam1.csv:1: the header mixes local columns",
        ),
        (
            lambda r: (r / "gcp_cam1.csv").write_text("u,v,x,y,z\n1,2,3,4,5\n1,2,3,4,5\n1,2,3,4,5\n5000,2,3,4,5\n"),
            r"gcp_cam1.csv:5: pixel \(5000, 2\) is outside the 800x600 image",
        ),
        (
            lambda r: _edit(r, 'intrinsics = "known.json"', 'intrinsics = "known.json"\nimages = "boards/*.png"'),
            r"give only one of images, video, intrinsics",
        ),
        (lambda r: _edit(r, 'pattern = "9x6"', 'pattern = "nine by six"'), r"key 'pattern': expected inner corners"),
        (lambda r: _edit(r, "square = 0.03", "sqare = 0.03"), r"unknown key 'sqare' \(did you mean 'square'\?\)"),
        (
            lambda r: _edit(r, "square = 0.03", 'square = 0.03\nmodel = "pinhole"'),
            r"key 'model': unknown model 'pinhole'",
        ),
        (lambda r: _edit(r, "origin = [", "origin = [91, "), r"key 'origin'"),
    ],
    ids=["few-gcps", "collinear", "mixed-columns", "outside", "two-sources", "pattern", "typo", "model", "origin"],
)
def test_bad_input_exits_2(project, damage, message):
    root, _ = project
    damage(root)
    result = _cli("calibrate", root / "project.toml", "--camera", "cam1", "--quiet")
    assert result.exit_code == 2, result.output
    assert re.search(message, result.output), result.output
    assert "Traceback" not in result.output
    assert not (root / "work" / "cameras" / "cam1" / "camera.json").exists()


def test_unknown_camera_name(project):
    root, _ = project
    result = _cli("calibrate", root / "project.toml", "--camera", "cam9")
    assert result.exit_code == 2 and "no camera named 'cam9'" in result.output


def test_a_failed_calibration_keeps_the_previous_artefacts(project):
    root, _ = project
    assert _cli("calibrate", root / "project.toml", "--camera", "cam1", "--quiet").exit_code == 0
    before = (root / "work" / "cameras" / "cam1" / "camera.json").read_text()
    (root / "gcp_cam1.csv").write_text("u,v,x,y,z\n1,2,3\n")
    assert _cli("calibrate", root / "project.toml", "--camera", "cam1", "--quiet").exit_code == 2
    assert (root / "work" / "cameras" / "cam1" / "camera.json").read_text() == before


@pytest.mark.slow
def test_the_executor_decides_how_many_processes_detect_the_boards(project, monkeypatch):
    """Alone in this process the intrinsics stage may use the executor's cores; in a pool's worker, one (no nested
    pool).
    """
    from tlsync_pipeline.pipeline.engine import run_graph
    from tlsync_pipeline.pipeline.executors import ProcessExecutor, SerialExecutor
    from tlsync_pipeline.pipeline.graph import build_graph
    from tlsync_pipeline.pipeline.stages import intrinsics

    root, _ = project
    graph = build_graph(load_project(root / "project.toml"), root / "work")
    workers = []
    original = intrinsics.calibrate_images
    # Record the processes the stage asks for (and detect with one here, to keep the test short).
    monkeypatch.setattr(
        intrinsics,
        "calibrate_images",
        lambda *a, **k: workers.append(k["workers"]) or original(*a, **{**k, "workers": 1}),
    )
    assert "intrinsics/cam0" in run_graph(graph, SerialExecutor(cores=3), targets=["intrinsics/cam0"]).ran
    assert workers == [3]

    class RecordingPool(ProcessExecutor):
        def __init__(self, jobs):
            super().__init__(jobs)
            self.cores_given = {}

        def submit(self, fn, kwargs):
            self.cores_given[kwargs["files"].task] = kwargs["files"].cores
            return super().submit(fn, kwargs)

    calibrations = ["calibrate/cam0", "calibrate/cam1"]
    cold = RecordingPool(2)
    summary = run_graph(graph, cold, force=set(calibrations), targets=calibrations)
    assert sorted(summary.ran) == calibrations and not summary.failed
    assert cold.cores_given == {}  # nothing submitted: light tasks run here while no worker is up

    pool = RecordingPool(2)
    summary = run_graph(graph, pool, force={"intrinsics/cam0", *calibrations}, targets=calibrations)
    assert sorted(summary.ran) == [*calibrations, "intrinsics/cam0"] and not summary.failed
    # The intrinsics task starts the workers and detects with one process there; the calibrations follow it onto them.
    assert pool.cores_given == {"intrinsics/cam0": 1, "calibrate/cam0": 1, "calibrate/cam1": 1}


@pytest.fixture(scope="module")
def unposed_project(tmp_path_factory):
    """A pass scene written as a project whose camera.json files have no pose: cam0's walker turns, cam1's walks
    straight.
    """
    from data_fixtures.passes import make_pass_scene
    from data_fixtures.scene import write_scene

    scene = make_pass_scene(3, paths=("turn", "straight", "turn")).scene
    root = tmp_path_factory.mktemp("unposed")
    write_scene(scene, root, poses=False)
    return root, scene


@pytest.mark.slow
def test_a_camera_without_a_pose_gets_it_from_the_target_and_a_straight_walk_fails_with_its_cause(unposed_project):
    root, scene = unposed_project
    result = _cli("run", root / "project.toml", "--quiet")
    assert result.exit_code == 1, result.output  # cam1 is not synchronized: never exit 0 with a wrong pose
    assert "straight_path" in result.output and "walk a curved path" in result.output
    work = root / "work"
    failed = read_camera(work / "cameras" / "cam1" / "camera.json")
    assert not failed.posed and "straight_path" in failed.extra["pose_error"]  # no pose, and why
    report = json.loads((work / "cameras" / "cam1" / "calibration_report.json").read_text())
    assert report["target_pose"]["cause"] == "straight_path" and "curved path" in report["target_pose"]["remedy"]
    timeline = json.loads((work / "timeline.json").read_text())
    assert set(timeline["cameras"]) == {"cam0", "cam2"} and "straight_path" in timeline["failed"]["cam1"]
    for name in ("cam0", "cam2"):
        camera = read_camera(work / "cameras" / name / "camera.json")
        truth = scene.true_cameras[name]
        # the CSV states no accuracy: the scatter of its fixes measures it (2 cm, RTK-grade), as the sync stage does
        assert camera.pose_info.source == "target" and camera.pose_info.for_3d
        assert np.linalg.norm(camera.center - truth.center) < 0.3 and angle_deg(camera.R, truth.R) < 1.0
        report = json.loads((work / "cameras" / name / "calibration_report.json").read_text())
        assert report["target_pose"]["source"] == "target" and report["target_pose"]["frames"] > 100
    html = (work / "report.html").read_text()
    assert "from the target" in html


def test_gcps_of_a_rough_survey_are_refined_by_the_target(unposed_project, tmp_path):
    from data_fixtures.passes import make_pass_scene

    root, scene = unposed_project
    gcps = make_pass_scene(3, paths=("turn", "straight", "turn"), gcp_noise_m=0.5).gcps["cam0"]
    shutil.copytree(root, tmp_path / "p", ignore=shutil.ignore_patterns("work"))
    folder = tmp_path / "p"
    write_gcp_csv(folder / "gcp_cam0.csv", gcps.uv, gcps.xyz)
    text = (folder / "project.toml").read_text()
    text = text.replace(
        'camera = "cam0/camera.json"',
        '[cameras.calibration]\nintrinsics = "cam0/camera.json"\ngcp = "gcp_cam0.csv"\ngcp_sigma_m = 0.5',
        1,
    )
    # the camera table's keys after [cameras.calibration] would land in it: move them above
    text = text.replace(
        '[cameras.calibration]\nintrinsics = "cam0/camera.json"\ngcp = "gcp_cam0.csv"\ngcp_sigma_m = 0.5\ntrack = '
        '"cam0/track.csv"\nfps = 30.0\n',
        'track = "cam0/track.csv"\nfps = 30.0\n[cameras.calibration]\nintrinsics = "cam0/camera.json"\ngcp = '
        '"gcp_cam0.csv"\ngcp_sigma_m = 0.5\n',
    )
    (folder / "project.toml").write_text(text)
    result = _cli("calibrate", folder / "project.toml", "--camera", "cam0", "--quiet")
    assert result.exit_code == 0, result.output
    report = json.loads((folder / "work" / "cameras" / "cam0" / "calibration_report.json").read_text())
    target = report["target_pose"]
    assert target["source"] == "gcp+target" and target["gcp_sigma_stated_m"] == 0.5
    assert 0.15 < target["gcp_sigma_m"] < 0.8  # measured from the points: 0.5 m per horizontal axis, none vertical
    assert len(target["gcps"]) == len(gcps.uv) and all(
        g["before_px"] is not None and g["after_px"] is not None for g in target["gcps"]
    )
    truth = scene.true_cameras["cam0"]
    camera = read_camera(folder / "work" / "cameras" / "cam0" / "camera.json")
    gcp_only = np.array(report["pose"]["camera_center_m"])
    assert np.linalg.norm(camera.center - truth.center) < 0.5 * np.linalg.norm(gcp_only - truth.center)
    assert target["moved_m"] == pytest.approx(np.linalg.norm(camera.center - gcp_only), abs=1e-6)


def test_the_pose_search_stays_near_the_scans_coarse_offset_only_when_the_video_was_read_in_windows():
    from dataclasses import replace

    from tlsync_pipeline.artefacts.scan import CoarseLine, ScanPlan
    from tlsync_pipeline.pipeline.stages.calibrate import COARSE_MARGIN_S, coarse_offsets

    scan = ScanPlan(False, "", ((500, 700),), 3000, CoarseLine(3.0, 600.0, 9, 0, 12, 1.0))
    lo, hi = coarse_offsets(scan, 30.0)
    assert lo == 600.0 - 30.0 * COARSE_MARGIN_S and hi == 600.0 + 30.0 * COARSE_MARGIN_S
    assert coarse_offsets(replace(scan, full=True), 30.0) is None  # every frame read: the target may be anywhere
    assert coarse_offsets(replace(scan, coarse=None), 30.0) is None
    assert coarse_offsets(scan, None) is None


def test_gcps_that_disagree_with_the_track_are_a_warning_that_names_them():
    from tlsync_pipeline.pipeline.stages.calibrate import pose_warnings

    report = {
        "pose": {"points": []},
        "target_pose": {"source": "gcp+target", "gcp_sigma_m": 0.3, "gcps_disagree": ["P2", "P5"]},
    }
    (left_out,) = pose_warnings(report)
    assert "P2, P5" in left_out and "left out of the pose" in left_out
    report["target_pose"]["source"] = "target"
    (fallback,) = pose_warnings(report)
    assert "P2, P5" in fallback and "the pose is the track's alone" in fallback
    report["target_pose"]["gcps_disagree"] = []
    assert pose_warnings(report) == ()


def test_a_pose_from_the_target_reads_the_log_model_the_sync_stage_reads(unposed_project, tmp_path):
    """Under a metre-level log the pose is fitted with the log's bias: [target] log_model and its overrides (the
    bias's correlation time too, which the vote stage does not read) are in the calibrate task's parameters, as the
    sync stage has them, so that changing them poses the camera again."""
    from tlsync_pipeline.pipeline.graph import build_graph

    root, _ = unposed_project
    shutil.copytree(root, tmp_path / "p", ignore=shutil.ignore_patterns("work"))
    toml = tmp_path / "p" / "project.toml"
    given = toml.read_text()
    assert 'trajectory = "trajectory.csv"\n' in given

    def params(keys: str):
        toml.write_text(given.replace('trajectory = "trajectory.csv"\n', f'trajectory = "trajectory.csv"\n{keys}', 1))
        project = load_project(toml)
        tasks = build_graph(project, project.default_work_dir, Options(progress=False)).tasks
        return tasks["calibrate/cam0"].params, tasks["sync"].params

    (undeclared, _), (drone, sync), (slower, _) = (
        params(""),
        params('log_model = "drone"\n'),
        params('log_model = "drone"\nbias_tau_s = 90.0\n'),
    )
    assert undeclared.target.log_model.name == "auto" and drone.target.log_model.name == "drone"
    assert drone.target.log_model == sync.log_model
    assert slower.target.log_model.tau_s == 90.0 and slower != drone != undeclared
