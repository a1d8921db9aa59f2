import numpy as np
import pytest

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.trajectory import Trajectory, read_trajectory, write_trajectory


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
