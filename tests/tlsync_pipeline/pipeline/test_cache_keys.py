"""Exact cache keys: a project key makes stale exactly the stages that read it, and status says which key changed.

The paper scene with cam1 bringing every mover (its target's rows and a
walker's) instead of a track, so that identify runs too.
"""

import shutil

import numpy as np
import pytest

from data_fixtures import make_scene, write_scene
from tlsync_pipeline.pipeline.engine import run_graph, status
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from trackers.detections import make_detections, write_detections


def _graph(folder):
    project = load_project(folder / "project.toml")
    return build_graph(project, project.default_work_dir, Options(progress=False))


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """The project after a complete run."""
    scene = make_scene(seed=0)
    folder = tmp_path_factory.mktemp("keys")
    write_scene(scene, folder)
    track = scene.tracks["cam1"]
    walker = np.column_stack([track.frame, track.x[::-1], track.y + 60.0])  # crosses the view, off the path
    fps = scene.cameras["cam1"].fps
    rows = [(f, f / fps, 1, x, y, 12.0, 12.0, 1.0) for f, x, y in zip(track.frame, track.x, track.y)]
    rows += [(f, f / fps, 2, x, y, 12.0, 12.0, 1.0) for f, x, y in walker]
    write_detections(make_detections(rows), folder / "cam1" / "detections.csv")
    toml = folder / "project.toml"
    toml.write_text(toml.read_text().replace('track = "cam1/track.csv"', 'detections = "cam1/detections.csv"'))
    summary = run_graph(_graph(folder))
    assert not summary.failed and {"identify/cam1", "vote/cam0", "vote/cam1", "sync", "render"} <= set(summary.ran)
    return folder


def _copy(finished, tmp_path):
    folder = tmp_path / "copy"
    shutil.copytree(finished, folder)
    return folder


def _edited(finished, tmp_path, old, new):
    folder = _copy(finished, tmp_path)
    toml = folder / "project.toml"
    assert old in toml.read_text()
    toml.write_text(toml.read_text().replace(old, new, 1))
    return folder


def _stale_by_own_reasons(folder) -> dict[str, list[str]]:
    """Tasks stale for a reason of their own (not only waiting for another), with those reasons."""
    own = {
        row.id: [r for r in row.reasons if not r.startswith("waits for")]
        for row in status(_graph(folder))
        if row.state == "stale"
    }
    return {tid: reasons for tid, reasons in own.items() if reasons}


@pytest.mark.parametrize(
    "old, new, stale, named",
    [
        ("seed = 0\n", "seed = 0\nmodel_error_px = 7.0\n", {"sync"}, "model_error_px: 1.0 -> 7.0"),
        ("eps_px = 10.0", "eps_px = 12.0", {"identify/cam1", "vote/cam0", "vote/cam1", "sync"}, "eps_px: 10.0 -> 12.0"),
        ("seed = 0\n", "seed = 0\nr_min = 0.02\n", {"identify/cam1", "sync"}, "r_min: 0.01 -> 0.02"),
        (
            "seed = 0\n",
            "seed = 0\nsmooth_trajectory = false\n",
            {"identify/cam1", "vote/cam0", "vote/cam1", "sync"},
            "smooth_trajectory: True -> False",
        ),
        ('name = "cam0"\n', 'name = "cam0"\nproxy = "never"\n', {"render"}, "proxy.cam0: 'auto' -> 'never'"),
        (
            'trajectory = "trajectory.csv"\n',
            'trajectory = "trajectory.csv"\nlog_model = "drone"\n',
            {"identify/cam1", "vote/cam0", "vote/cam1", "sync"},
            "log_model.name: 'auto' -> 'drone'",
        ),
        (
            'trajectory = "trajectory.csv"\n',
            'trajectory = "trajectory.csv"\nbias_tau_s = 30.0\n',
            {"sync"},
            "log_model.tau_s: None -> 30.0",
        ),
    ],
    ids=["model_error_px", "eps_px", "r_min", "smooth_trajectory", "proxy", "log_model", "bias_tau_s"],
)
def test_a_key_makes_stale_exactly_the_stages_that_read_it(finished, tmp_path, old, new, stale, named):
    folder = _edited(finished, tmp_path, old, new)
    found = _stale_by_own_reasons(folder)
    assert set(found) == stale
    assert all(any(named in reason for reason in reasons) for reasons in found.values()), found


def test_a_key_only_the_intervals_read_reruns_sync_export_and_render_only(finished, tmp_path):
    folder = _edited(finished, tmp_path, "seed = 0\n", "seed = 0\nmodel_error_px = 7.0\n")
    summary = run_graph(_graph(folder))
    assert sorted(summary.ran) == ["export", "render", "sync"]
    assert {"identify/cam1", "vote/cam0", "vote/cam1"} <= set(summary.fresh)


@pytest.mark.parametrize(
    "module, stale",
    [
        ("tlsync_pipeline.sync.solve.log_bias", {"sync", "render"}),
        ("tlsync_pipeline.sync.timeline", {"sync", "export", "render"}),
    ],
    ids=["log_bias", "timeline"],
)
def test_a_code_edit_makes_stale_exactly_the_stages_that_run_it(finished, tmp_path, monkeypatch, module, stale):
    """A comment appended to the log's bias fit or to the timeline's writer: identify and vote stay fresh
    (the stages before them, too: tests/tlsync_pipeline/pipeline/test_cache_scope.py)."""
    from tlsync_pipeline.pipeline import codehash

    folder = _copy(finished, tmp_path)
    original = codehash.module_source
    monkeypatch.setattr(
        codehash, "module_source", lambda name: original(name) + (b"\n# a comment\n" if name == module else b"")
    )
    found = _stale_by_own_reasons(folder)
    assert set(found) == stale
    assert all(any(f"code of {module}" in reason for reason in reasons) for reasons in found.values()), found


@pytest.fixture(scope="module")
def finished_with_a_log(tmp_path_factory):
    """The paper scene with its trajectory given as a GPX log (the ingest stage runs), after a complete run."""
    from data_fixtures.gps_logs import write_gpx_log
    from tlsync_pipeline.geodesy import Origin

    scene = make_scene(seed=0)
    folder = tmp_path_factory.mktemp("log_keys")
    write_scene(scene, folder)
    origin = Origin(46.5, 6.6, 380.0)
    write_gpx_log(folder / "target.gpx", scene.trajectory, origin, 1.7e9)
    toml = folder / "project.toml"
    given = 'trajectory = "trajectory.csv"\n'
    assert given in toml.read_text()
    toml.write_text(
        toml.read_text().replace(given, f'log = "target.gpx"\norigin = [{origin.lat}, {origin.lon}, {origin.alt}]\n')
    )
    summary = run_graph(_graph(folder))
    assert {"ingest", "vote/cam0", "sync"} <= set(summary.ran)
    return folder


VOTE_AND_SYNC = {"vote/cam0", "vote/cam1", "sync"}


@pytest.mark.parametrize(
    "new, stale",
    [("bias_tau_s = 30.0", {"sync"}), ('log_model = "drone"', VOTE_AND_SYNC), ("white_sigma_m = 0.5", VOTE_AND_SYNC)],
    ids=["bias_tau_s", "log_model", "white_sigma_m"],
)
def test_a_key_of_the_logs_error_model_leaves_ingest_fresh(finished_with_a_log, tmp_path, new, stale):
    """[target]'s error-model keys are read by vote (the sizes of the errors: its radius) and sync, not by ingest: the
    log is not parsed again; the bias's correlation time only by sync's fit."""
    folder = _edited(finished_with_a_log, tmp_path, 'log = "target.gpx"\n', f'log = "target.gpx"\n{new}\n')
    assert set(_stale_by_own_reasons(folder)) == stale
    summary = run_graph(_graph(folder))
    assert "ingest" in summary.fresh and "sync" in summary.ran


def test_a_key_ingest_reads_makes_it_stale(finished_with_a_log, tmp_path):
    folder = _edited(finished_with_a_log, tmp_path, 'log = "target.gpx"\n', 'log = "target.gpx"\nsmoothing_s = 0.5\n')
    assert "smoothing_s: 0.0 -> 0.5" in " ".join(_stale_by_own_reasons(folder)["ingest"])
