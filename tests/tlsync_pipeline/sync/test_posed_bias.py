"""The guard on the poses' refit under the joint bias (sync/solve/posed_bias.py): the refit is kept only where the
lines stay where the poses alone allow, and not tried where the first joint fit already leaves them far."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve import posed_bias
from tlsync_pipeline.sync.solve.posed_bias import GIVE_UP_MOVE, MAX_MOVE, ROUNDS, line_moves, refit_hopeless, refit_kept
from tlsync_pipeline.sync.timeline import CameraLine, LogCorrection
from tlsync_pipeline.trajectory import Trajectory


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


def test_the_refit_is_hopeless_when_a_line_already_moved_beyond_the_give_up_move_or_none_can_be_measured():
    assert GIVE_UP_MOVE > MAX_MOVE
    assert not refit_hopeless({"a": 0.5, "b": GIVE_UP_MOVE})
    assert refit_hopeless({"a": 0.5, "b": 1.01 * GIVE_UP_MOVE})
    assert refit_hopeless({})


class _ShiftingJointFit:
    """A joint fit that moves every line's beta by the next of ``shifts`` (frames), one a call."""

    def __init__(self, shifts: list[float]):
        self.shifts = list(shifts)

    def refine_with_log_bias(self, cameras, lines, trajectory, params, options, model):
        shift = self.shifts.pop(0)
        moved = {n: CameraLine(n, line.alpha, line.beta + shift, 100, 90, 1.0, 30.0) for n, line in lines.items()}
        return moved, object()


@pytest.mark.parametrize(
    ("stds", "given_up"),
    [
        ([2 * GIVE_UP_MOVE] * (ROUNDS - 1) + [0.5 * GIVE_UP_MOVE], False),  # the earlier rounds' fits are no guide
        ([0.5 * GIVE_UP_MOVE] * (ROUNDS - 1) + [2 * GIVE_UP_MOVE], True),
    ],
)
def test_the_refit_is_given_up_when_the_last_rounds_joint_fit_moved_a_line_beyond_the_give_up_move(
    monkeypatch, stds, given_up
):
    zero = LogCorrection(np.zeros(1), np.zeros((1, 3)), "bias_refit")
    monkeypatch.setattr(posed_bias, "bias_correction", lambda bias: zero)
    monkeypatch.setattr(posed_bias, "PiecewiseTrajectory", lambda trajectory: trajectory)
    monkeypatch.setattr(posed_bias, "refit_pose", lambda *args: None)  # every pose's refit fails: its line stays
    lines = {name: _line(name, -100.0, 2.0) for name in "ab"}
    data = {name: SimpleNamespace(track_clock=np.arange(1000.0)) for name in "ab"}
    method = _ShiftingJointFit([2.0 * std for std in stds])  # each line's std is 2 frames
    log = Trajectory(np.arange(3.0), np.zeros((3, 3)), 10.0, 0.0)

    refit = posed_bias.refit_poses(method, data, lines, {"a", "b"}, log, SyncParams(), None)  # type: ignore[arg-type]
    assert (refit is None) == given_up
    assert given_up or refit.correction is zero  # the last round's bias: the log the poses were refitted on
    assert not method.shifts  # every round's joint fit was made
