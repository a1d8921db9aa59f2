import numpy as np
import pytest

from trackers.errors import TrackInputError
from trackers.track import Track, read_track, write_track


def test_round_trip_keeps_optional_columns_and_sorts(tmp_path):
    track = Track(
        np.array([0, 3, 7]),
        np.array([1.5, 2.25, 3.0]),
        np.array([4.0, 5.0, 6.125]),
        time_s=np.array([0.0, 0.1, 0.2333]),
    )
    write_track(track, tmp_path / "t.csv")
    back = read_track(tmp_path / "t.csv")
    assert back.frame.tolist() == [0, 3, 7]
    np.testing.assert_allclose(back.y, track.y)
    np.testing.assert_allclose(back.time_s, track.time_s, atol=1e-6)
    assert back.w is None and back.score is None

    (tmp_path / "u.csv").write_text("x,frame,y\n1,5,2\n3,1,4\n")
    unsorted = read_track(tmp_path / "u.csv")
    assert unsorted.frame.tolist() == [1, 5] and unsorted.x.tolist() == [3.0, 1.0]


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty file"),
        ("frame,x,y\n", "the track is empty"),
        ("frame,x\n0,1\n", "lacks column"),
        ("frame,x,y\n0,1,2\n1,abc,2\n", r":3: column 'x': not a number"),
        ("frame,x,y\n0,1,2\n1,nan,2\n", r":3: column 'x': nan is not a finite"),
        ("frame,x,y\n0,1,inf\n", r":2: column 'y'"),
        ("frame,x,y\n0,1,2\n1,2\n", r":3: expected 3 fields"),
        ("frame,x,y\n0,1,2\n\n1,2,3\n-2,1,2\n", r":5: column 'frame'"),  # line numbers count the blank line
        ("frame,x,y\n0,1,2\n1,2,3,4\n", r":3: expected 3 fields"),
        ("frame,x,y\n-1,1,2\n", "0-based integer frame"),
        ("frame,x,y\n1.5,1,2\n", "0-based integer frame"),
        ("frame,x,y\n2,1,2\n2,1,2\n", "frame 2 appears more than once"),
        (
            "frame,x,y\n0,1,2\n0.04,1,2\n0.08,1,2\n0.12,1,2\n",
            r":3: column 'frame' holds times, not frame indices \(75% of its values",
        ),
    ],
)
def test_bad_tracks_name_file_and_line(tmp_path, text, message):
    """Well-formed tables take NumPy's parser; anything else the line-by-line reader, which names the line."""
    path = tmp_path / "track.csv"
    path.write_text(text)
    with pytest.raises(TrackInputError, match=message) as info:
        read_track(path)
    assert str(path) in str(info.value)


def test_both_readers_agree(tmp_path):
    """A blank line sends a table to the line-by-line reader: the values are the same as NumPy's parser gives."""
    rows = [f"{k},{k * 1.5:.6f},{-k / 3:.6f},{k / 25:.6f}" for k in range(50)]
    plain, spaced = tmp_path / "plain.csv", tmp_path / "spaced.csv"
    plain.write_text("frame,x,y,time_s\n" + "\n".join(rows) + "\n")
    spaced.write_text("frame,x,y,time_s\n" + "\n".join(rows[:20]) + "\n\n" + "\n".join(rows[20:]) + "\n")
    a, b = read_track(plain), read_track(spaced)
    for column in ("frame", "x", "y", "time_s"):
        assert np.array_equal(getattr(a, column), getattr(b, column))


@pytest.mark.parametrize(
    "text",
    [
        "\ufeffframe,x,y,score\n0,1.5,2.25,0.9\n3,4,5.5,1\n",  # UTF-8 with a byte-order mark (Excel's "CSV UTF-8")
        "frame;x;y;score\r\n0;1,5;2,25;0,9\r\n3;4;5,5;1\r\n",  # a European locale: ';' separators, decimal commas
        "\ufeffframe;x;y;score\n0;1,5;2,25;0,9\n\n3;4;5,5;1\n",  # both, with a blank line (the line-by-line reader)
        "frame\tx\ty\tscore\n0\t1,5\t2,25\t0,9\n3\t4\t5,5\t1\n",  # tabs
    ],
)
def test_csvs_saved_by_a_spreadsheet_are_read(tmp_path, text):
    path = tmp_path / "track.csv"
    path.write_text(text, encoding="utf-8")
    track = read_track(path)
    assert track.frame.tolist() == [0, 3] and track.x.tolist() == [1.5, 4.0] and track.y.tolist() == [2.25, 5.5]
    assert track.score.tolist() == [0.9, 1.0]


def test_a_file_that_is_not_a_table_is_described_not_quoted(tmp_path):
    """A passwd-like file given as a track: the message names the file, line and what was found, never its text."""
    path = tmp_path / "passwd"
    path.write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n")
    with pytest.raises(TrackInputError) as info:
        read_track(path)
    message = str(info.value)
    assert message.startswith(
        f"{path}:1: not a CSV header: one field of 31 characters"
    ) and "root" not in message.replace(str(path), "")
    path.write_text("frame,x,y\n0,1,2\n1,secret-token,3\n")
    with pytest.raises(TrackInputError, match=r":3: column 'x': not a number \(12 characters with letters\)") as info:
        read_track(path)
    assert "secret" not in str(info.value).replace(str(path), "")
