"""timeline.json: typed camera lines written and read back; pairs of variable-frame-rate cameras are
marked approximate.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from data_fixtures import make_scene
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.outputs.summary import format_table
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import read_timeline, write_timeline


def _timeline(**scene_args):
    scene = make_scene(0, lines=((2.0, 45.61), (1.5, 4.37)), tracking_noise_px=1.0, **scene_args)
    inputs = {n: CameraInput(scene.cameras[n], scene.tracks[n], scene.cameras[n].fps) for n in scene.cameras}
    return synchronize(inputs, scene.trajectory, SyncParams())[0]


def test_camera_lines_read_back_typed(tmp_path):
    timeline = _timeline(frame_time_jitter=0.1)
    write_timeline(timeline, tmp_path / "timeline.json")
    back = read_timeline(tmp_path / "timeline.json")
    for name, line in timeline.cameras.items():
        again = back.cameras[name]
        assert again.clock == line.clock and line.clock.kind == "time_s"
        assert again.line_search == line.line_search and again.refinement == line.refinement
        assert (again.flags, again.warnings, again.refined) == (line.flags, line.warnings, line.refined)
        np.testing.assert_array_equal(again.cov, line.cov)
        assert (again.alpha, again.beta, again.fps) == (line.alpha, line.beta, line.fps)
    assert back.relation("cam0", "cam1") == timeline.relation("cam0", "cam1")
    data = json.loads((tmp_path / "timeline.json").read_text())
    camera = data["cameras"]["cam1"]
    assert {"clock", "clock_fps", "clock_origin_s", "time_jitter_frames", "line_search", "refinement", "cov"} <= set(
        camera
    )
    pair = data["pairs"]["cam0->cam1"]
    assert pair["approximate"] is True and pair["exact"] == "exports/frame_map.csv"
    assert "variable frame rate: cam0, cam1: starts in frames are approximate" in format_table(back)


def test_constant_rate_cameras_keep_frame_indices_and_exact_pairs(tmp_path):
    timeline = _timeline()
    write_timeline(timeline, tmp_path / "timeline.json")
    data = json.loads((tmp_path / "timeline.json").read_text())
    assert not {"clock", "clock_origin_s"} & set(data["cameras"]["cam0"])
    assert "approximate" not in data["pairs"]["cam0->cam1"] and "variable frame rate" not in format_table(timeline)
    frames = np.arange(0.0, 500.0, 7.0)
    # Without presentation times, match and relation are the same mapping.
    np.testing.assert_allclose(
        timeline.match("cam0", "cam1", frames), timeline.relation("cam0", "cam1")(frames), rtol=0, atol=1e-9
    )


def test_a_malformed_camera_entry_names_the_file(tmp_path):
    write_timeline(_timeline(), tmp_path / "timeline.json")
    data = json.loads((tmp_path / "timeline.json").read_text())
    data["cameras"]["cam0"]["line_search"] = {"alpha": 1.0}
    (tmp_path / "timeline.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="timeline.json: not a tlsync timeline"):
        read_timeline(tmp_path / "timeline.json")
