"""The guard on the poses' refit under the joint bias (sync/solve/posed_bias.py): the refit is kept only where the
lines stay where the poses alone allow."""

from __future__ import annotations

import numpy as np

from tlsync_pipeline.sync.solve.posed_bias import MAX_MOVE, line_moves, refit_kept
from tlsync_pipeline.sync.timeline import CameraLine


def _line(name: str, beta: float, beta_std: float) -> CameraLine:
    return CameraLine(name, 0.25, beta, 100, 90, 1.0, 30.0, cov=np.diag([0.0, beta_std**2]))


def test_a_lines_move_is_measured_at_its_middle_frame_in_its_pose_alones_std():
    alone = {"a": _line("a", -100.0, 4.0)}
    refitted = {"a": CameraLine("a", 0.26, -100.0, 100, 90, 1.0, 30.0)}
    middle = 500.0  # sample 2400 alone; the refit's slope puts that frame 0.26 * (2307.7 - 2400) frames away
    move = line_moves({"a": middle}, alone, refitted)["a"]
    assert np.isclose(move, 0.26 * abs((middle + 100.0) / 0.26 - (middle + 100.0) / 0.25) / 4.0)


def test_the_refit_is_kept_when_the_lines_move_within_the_poses_alone_and_not_when_they_leave_them():
    alone = {name: _line(name, -100.0, 10.0) for name in "abc"}
    near = {name: _line(name, -100.0 + shift, 1.0) for name, shift in zip("abc", (3.0, -6.0, 4.0))}
    far = {name: _line(name, -100.0 + shift, 1.0) for name, shift in zip("abc", (-3.0, 7.0, 11.0))}
    middles = {name: 500.0 for name in "abc"}
    assert refit_kept(line_moves(middles, alone, near))
    assert not refit_kept(line_moves(middles, alone, far))
    assert not refit_kept({})
    assert refit_kept({"a": MAX_MOVE}) and not refit_kept({"a": 1.01 * MAX_MOVE})
