import pytest

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.pipeline.project import load_project


def _write(tmp_path, text):
    path = tmp_path / "project.toml"
    path.write_text(text)
    return path


def test_paths_are_relative_to_the_project_and_defaults_apply(tmp_path):
    sub = tmp_path / "p"
    sub.mkdir()
    project = load_project(
        _write(
            sub,
            '[target]\ntrajectory = "t.csv"\n[[cameras]]\nname = "a"\ncamera = "a/c.json"\nfps = 25\n[sync]\neps_px = '
            "12\nlogged_point_above_m = -0.2\n",
        )
    )
    assert project.target.trajectory == sub / "t.csv"
    assert project.cameras[0].camera == sub / "a" / "c.json"
    assert project.cameras[0].track is None
    assert project.cameras[0].tracker.kind == "blob" and project.cameras[0].calibration.ransac_px == 8.0
    assert project.sync.eps_px == 12.0 and project.sync.delta == 0.5 and project.sync.options["paper"].r == 0.05
    assert project.sync.logged_point_above_m == -0.2  # below the tracked point: any number


@pytest.mark.parametrize(
    "text, message",
    [
        ('[[cameras]]\nname = "a"\nfsp = 30\n', r"\[cameras #1\]: unknown key 'fsp' \(did you mean 'fps'\?\)"),
        ('[sync]\neps = 3\n[[cameras]]\nname = "a"\n', r"did you mean 'eps_px'"),
        ('[targt]\n[[cameras]]\nname = "a"\n', r"did you mean 'target'"),
        ('[[cameras]]\nname = "a"\n[[cameras]]\nname = "a"\n', "duplicate camera name 'a'"),
        ("[[cameras]]\nfps = 3\n", "missing required key 'name'"),
        ('[[cameras]]\nname = "a"\nfps = -3\n', "'fps': expected a positive number"),
        ('[sync]\np = 1.5\n[[cameras]]\nname = "a"\n', "'p': expected a number strictly between 0 and 1"),
        ('[sync]\nseed = 0.5\n[[cameras]]\nname = "a"\n', "'seed': expected an integer"),
        (
            '[sync]\nlogged_point_above_m = "head"\n[[cameras]]\nname = "a"\n',
            "'logged_point_above_m': expected a number",
        ),
        ("[target]\ntrajectory = 'x.csv'\n", r"no \[\[cameras\]\]"),
        (
            '[calibration]\ngcp_sigma_m = -1\n[[cameras]]\nname = "a"\n',
            r"\[calibration\]: key 'gcp_sigma_m': expected a number >= 0",
        ),
        ('[[cameras]]\nname = "a"\n[cameras.calibration]\ngcp_sigma = 1\n', r"did you mean 'gcp_sigma_m'"),
        ("[target\n", "invalid TOML"),
    ],
)
def test_bad_projects(tmp_path, text, message):
    with pytest.raises(InputError, match=message):
        load_project(_write(tmp_path, text))


def test_missing_project_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        load_project(tmp_path / "none.toml")


def test_the_gcp_survey_sigma_is_project_wide_unless_a_camera_says_otherwise(tmp_path):
    from tlsync_pipeline.pipeline.stages.calibrate import gcp_sigma

    text = '[[cameras]]\nname = "a"\n[[cameras]]\nname = "b"\n[cameras.calibration]\ngcp_sigma_m = 0.02\n'
    default = load_project(_write(tmp_path, text))
    assert default.calibration.gcp_sigma_m == 1.0  # a web map or a phone
    assert gcp_sigma(default, "a") == 1.0 and gcp_sigma(default, "b") == 0.02
    project = load_project(_write(tmp_path, "[calibration]\ngcp_sigma_m = 0\n" + text))
    assert gcp_sigma(project, "a") == 0.0 and gcp_sigma(project, "b") == 0.02
