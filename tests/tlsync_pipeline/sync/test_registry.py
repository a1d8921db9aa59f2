"""The sync-method registry: a method added as one module plus its registration runs like the built-in ones."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from data_fixtures import make_scene, write_scene
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.sync.model.methods import METHODS, params_from_table, params_table
from tlsync_pipeline.sync.model.params import SyncParams, param
from tlsync_pipeline.sync.solve.registry import get_method, register
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import eps_t, read_timeline

from .toy_method import ToyMethod, ToyParams


@pytest.fixture
def toy():
    """The toy method registered for one test (the registry is restored after it)."""
    saved = dict(METHODS)
    yield register(ToyMethod())
    METHODS.clear()
    METHODS.update(saved)


def test_the_built_in_methods_are_registered():
    assert {"paper", "refined"} <= set(METHODS)
    with pytest.raises(ValueError, match="unknown sync method 'ransac'; methods: paper, refined"):
        get_method("ransac")


def test_a_toy_method_runs_through_synchronize(toy):
    scene = make_scene(0)
    inputs = {n: CameraInput(scene.cameras[n], scene.tracks[n], scene.cameras[n].fps) for n in scene.cameras}
    timeline, results = synchronize(inputs, scene.trajectory, SyncParams(method="toy", options={"toy": ToyParams(8.0)}))
    assert not timeline.failed and timeline.method == "toy"
    assert (
        timeline.params.own["toy_max_dist_px"] == 8.0
        and timeline.params.own["r_min"] == 0.01
        and timeline.params.shared.method == "toy"
    )
    for key, true in scene.truth_pairs().items():  # a crude method: whole frames off, not hundreds
        assert eps_t(timeline.relation(*key.split("->")), true, scene.n_frames[key.split("->")[0]]) < 3.0, key
    assert all(line.flags == ("toy",) and line.cov is None for line in timeline.cameras.values())
    assert all(len(r.votes) == r.line.votes for r in results.values())


def test_a_toy_method_is_a_project_choice_and_runs_in_the_pipeline(toy, tmp_path):
    project_file = write_scene(make_scene(1, n_frames=300), tmp_path)
    text = project_file.read_text()
    project_file.write_text(text.replace("seed = 0\n", 'seed = 0\nmethod = "toy"\ntoy_max_dist_px = 6.0\n'))
    project = load_project(project_file)
    assert project.sync.method == "toy" and project.sync.options["toy"] == ToyParams(6.0)
    summary = run_graph(build_graph(project, tmp_path / "work"), targets=["sync"])
    assert not summary.failed
    timeline = read_timeline(tmp_path / "work" / "timeline.json")
    assert timeline.method == "toy" and all(line.flags == ("toy",) for line in timeline.cameras.values())
    project_file.write_text(text.replace("seed = 0\n", "seed = 0\ntoy_max_dist_px = -1\n"))
    with pytest.raises(InputError, match="'toy_max_dist_px': expected a positive number"):
        load_project(project_file)


def test_registration_refuses_a_taken_name_or_parameter(toy):
    with pytest.raises(ValueError, match="already registered"):
        register(ToyMethod())

    @dataclass(frozen=True)
    class ClashParams:
        r: float = param(0.1, "ratio")

    class Clash(ToyMethod):
        name = "clash"
        params_type = ClashParams

    with pytest.raises(ValueError, match="parameter\\(s\\) r already used"):
        register(Clash())


def test_the_sync_table_round_trips():
    params = SyncParams(eps_px=7.0, method="paper", options={"paper": METHODS["paper"].params_type(r=0.2)})
    table = params_table(params)
    assert table["eps_px"] == 7.0 and table["r"] == 0.2 and table["smooth_trajectory"] is True
    again = params_from_table(table)
    assert params_table(again) == table and np.isclose(again.options["paper"].r, 0.2)
