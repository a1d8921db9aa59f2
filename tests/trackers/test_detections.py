"""detections.csv: round trip, validation messages naming file and line, single-target tracks from
rows, init-box seeds.
"""

import numpy as np
import pytest

from trackers.detections import make_detections, read_detections, seed_tracklets, write_detections
from trackers.errors import TrackInputError
from trackers.track import Track


def _sample():
    return make_detections(
        [
            (3, 0.3, 1, 50.0, 60.0, 10, 20, 0.9),
            (0, 0.0, 0, 10.5, 20.25, 8, 16, 0.5),
            (0, 0.0, 1, 30.0, 40.0, 9, 18, 0.7),
            (1, 0.1, 0, 11.5, 21.25, 8, 16, 0.8),
        ]
    )


def test_round_trip_keeps_every_row_sorted_by_frame_then_id(tmp_path):
    path = tmp_path / "detections.csv"
    write_detections(_sample(), path)
    assert path.read_text().splitlines()[0] == "frame,time_s,id,x,y,w,h,score"
    back = read_detections(path)
    assert back.frame.tolist() == [0, 0, 1, 3]
    assert back.id.tolist() == [0, 1, 0, 1]
    np.testing.assert_allclose(back.xy, [[10.5, 20.25], [30.0, 40.0], [11.5, 21.25], [50.0, 60.0]])
    np.testing.assert_allclose(back.time_s, [0.0, 0.0, 0.1, 0.3])


def test_minimal_columns_get_defaults(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("frame,id,x,y\n0,4,1,2\n2,4,3,4\n")
    back = read_detections(path)
    assert back.score.tolist() == [1.0, 1.0]
    assert np.isnan(back.time_s).all()
    track = back.to_track(np.array([0, 1]))
    assert track.time_s is None and track.frame.tolist() == [0, 2]


@pytest.mark.parametrize(
    "text, message",
    [
        ("frame,x,y\n0,1,2\n", "lacks column(s) id"),
        ("frame,id,x,y\n0,1,2,abc\n", ":2: column 'y': not a number"),
        ("frame,id,x,y\n0,1,2,3\n1.5,1,2,3\n", ":3: column 'frame': expected a 0-based integer"),
        ("frame,id,x,y\n0,-1,2,3\n", "non-negative integer tracklet id"),
        ("frame,id,x,y\n0,1,2,3\n0,1,5,6\n", "tracklet 1 has two detections in frame 0"),
        ("frame,id,x,y\n", "no detection"),
    ],
)
def test_bad_files_are_named_with_the_line(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(TrackInputError, match="bad.csv") as info:
        read_detections(path)
    assert message in str(info.value)


def test_a_track_takes_one_row_per_frame():
    detections = _sample()
    with pytest.raises(ValueError, match="at most one"):
        detections.to_track(np.array([0, 1]))
    track = detections.to_track(detections.id == 0)
    assert track.frame.tolist() == [0, 1]


def test_an_init_box_points_at_the_mover_inside_it_nearest_its_frame_and_centre():
    rows = [
        (10, 1.0, 1, 50.0, 50.0, 10, 20, 0.9),  # inside the box, at the init frame, off its centre
        (10, 1.0, 2, 44.0, 44.0, 10, 20, 0.9),  # inside, nearer the centre
        (10, 1.0, 3, 200.0, 50.0, 10, 20, 0.9),  # elsewhere
        (12, 1.2, 4, 45.0, 45.0, 10, 20, 0.9),  # inside, two frames later
    ]
    movers = make_detections(rows)
    assert seed_tracklets(movers, (35, 30, 20, 30), 10) == {2}
    assert seed_tracklets(movers, (35, 30, 20, 30), 13) == {4}  # the nearest frame first
    assert seed_tracklets(movers, (35, 30, 20, 30), 30) == frozenset()  # nothing within SEED_FRAMES
    assert seed_tracklets(movers, (300, 300, 20, 30), 10) == frozenset()


def test_a_track_matches_the_box_its_position_was_taken_from():
    movers = make_detections(
        [
            (0, 0.0, 1, 100.0, 100.0, 60, 100, 0.9),  # a merged blob: the track holds its left part
            (0, 0.0, 2, 200.0, 100.0, 20, 50, 0.9),
            (1, 0.1, 1, 105.0, 100.0, 20, 50, 0.9),  # the track's own blob, and a fragment next to it
            (1, 0.1, 3, 108.0, 104.0, 4, 4, 0.5),
            (2, 0.2, 2, 300.0, 100.0, 20, 50, 0.9),  # a frame the track does not hold
        ]
    )
    track = Track(np.array([0, 1]), np.array([80.0, 105.0]), np.array([100.0, 100.0]))
    assert movers.matching(track).tolist() == [True, False, True, False, False]
    assert not movers.matching(Track(np.array([0]), np.array([140.0]), np.array([100.0]))).any()  # outside every box
