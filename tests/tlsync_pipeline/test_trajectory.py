import numpy as np
import pytest

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory, grid_rate, read_trajectory, write_trajectory


def test_times_define_the_grid_and_gaps_stay_gaps(tmp_path):
    path = tmp_path / "traj.csv"
    path.write_text("t,x,y,z\n100.0,0,0,0\n100.2,1,0,0\n100.4,2,0,0\n101.0,5,0,0\n101.2,6,0,0\n")
    traj = read_trajectory(path)
    assert traj.rate == pytest.approx(5.0)
    assert traj.t0 == 100.0
    np.testing.assert_allclose(traj.sample, [0, 1, 2, 5, 6])
    assert traj.seconds(5.0) == pytest.approx(101.0)


def test_without_times_samples_are_rows(tmp_path):
    path = tmp_path / "traj.csv"
    path.write_text("x,y,z\n0,0,0\n1,1,1\n2,2,2\n")
    traj = read_trajectory(path)
    assert traj.sample.tolist() == [0, 1, 2] and traj.rate is None


def test_round_trip(tmp_path):
    sample = np.array([0.0, 1.0, 2.0, 3.0, 7.0, 8.0])  # a gap of three samples
    traj = Trajectory(sample, np.arange(18.0).reshape(6, 3), 10.0, 5.0)
    write_trajectory(traj, tmp_path / "t.csv")
    back = read_trajectory(tmp_path / "t.csv")
    np.testing.assert_allclose(back.sample, traj.sample)
    np.testing.assert_allclose(back.xyz, traj.xyz)
    assert back.t0 == 5.0


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty file"),
        ("x,y,z\n1,2,3\n", "1 sample"),
        ("a,b,c\n1,2,3\n", "lacks column"),
        ("x,y,z\n1,2,3\n1,2,oops\n", r":3: column 'z': not a number"),
        ("t,x,y,z\n0,1,2,3\n1,1,2,inf\n", r":3: column 'z'"),
        ("t,x,y,z\n0,1,2,3\n1,1,2,3\n0.5,1,2,3\n", r":4: time 0.5 s goes backwards"),
        ("t,x,y,z\n0,1,2,3\n0,1,2,3\n", r":3: time 0 s repeats"),
        ("time,lat,lon,alt\n0,1,2,3\n1,1,2,3\n", "geodetic"),
    ],
)
def test_bad_trajectories(tmp_path, text, message):
    path = tmp_path / "traj.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        read_trajectory(path)
    assert str(path) in str(info.value)


def test_interpolation_never_bridges_a_gap():
    sample = np.r_[np.arange(0, 10.0), np.arange(20, 30.0)]
    xyz = np.column_stack([sample, np.zeros_like(sample), np.zeros_like(sample)])
    path = PiecewiseTrajectory(Trajectory(sample, xyz))
    run = path.run_of(np.array([4.5, 15.0, 25.5]))
    assert list(run) == [0, -1, 1]
    assert np.allclose(path(np.array([4.5, 25.5]), run[[0, 2]])[:, 0], [4.5, 25.5])
    # positions(): NaN outside the runs (before, in the gap, after).
    positions = path.positions([-1.0, 4.5, 15.0, 29.0, 31.0])
    assert np.isnan(positions[[0, 2, 4], 0]).all() and np.allclose(positions[[1, 3], 0], [4.5, 29.0])


def test_grid_rate_of_rounded_times_with_gaps():
    # 15 Hz written to the millisecond, with a gap of 4 samples: the grid rate, not 1 / median interval.
    k = np.r_[np.arange(0, 100), np.arange(104, 200)]
    t = np.round(1_700_000_000.0 + k / 15.0, 3)
    assert grid_rate(t) == pytest.approx(15.0, rel=1e-6)
    assert abs(1.0 / np.median(np.diff(t)) - 15.0) > 1e-3
