"""The ingest stage's parameters hold the [target] keys it reads, and only those."""

from __future__ import annotations

import pytest

from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.pipeline.stages.ingest import SPEC

CAMERA = '[[cameras]]\nname = "cam0"\ncamera = "camera.json"\ntrack = "track.csv"\n'


def _params(tmp_path, target: str):
    toml = tmp_path / "project.toml"
    toml.write_text(f"[target]\n{target}\n{CAMERA}", encoding="utf-8")
    return SPEC.params(load_project(toml), None, Options(progress=False))


@pytest.mark.parametrize(
    "given, other",
    [
        ('log = "target.gpx"', 'log_model = "phone"\nwhite_sigma_m = 0.5\nbias_sigma_m = 2.0\nbias_tau_s = 30.0'),
        ('trajectory = "t.csv"\ntime_unit = "ms"', 'smoothing_s = 2.0\nrate = 5.0\nformat = "gpx"\nbias_tau_s = 30.0'),
    ],
    ids=["log", "trajectory in ms"],
)
def test_keys_the_ingest_stage_does_not_read_leave_its_parameters(tmp_path, given, other):
    assert _params(tmp_path, f"{given}\n{other}") == _params(tmp_path, given)


@pytest.mark.parametrize(
    "given, read",
    [
        ('log = "target.gpx"', "smoothing_s = 2.0"),
        ('log = "target.gpx"', "origin = [46.5, 6.6, 380.0]"),
        ('trajectory = "t.csv"\ntime_unit = "ms"', 'length_unit = "ft"'),
    ],
)
def test_keys_it_reads_change_them(tmp_path, given, read):
    assert _params(tmp_path, f"{given}\n{read}") != _params(tmp_path, given)
