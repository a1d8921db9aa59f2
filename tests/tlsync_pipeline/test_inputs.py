"""Input files: regular, bounded, text where text is expected; quotes stay short."""

from __future__ import annotations

import os

import pytest

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.inputs import quote, read_text_file, regular_file
from trackers.errors import TrackInputError
from trackers.track import read_track


def test_only_regular_files_of_bounded_size_outside_the_system(tmp_path):
    good = tmp_path / "track.csv"
    good.write_text("frame,x,y\n0,1,2\n")
    assert regular_file(good, 1000) == good
    with pytest.raises(InputError, match="larger than any"):
        regular_file(good, 4)
    with pytest.raises(InputError, match="a folder"):
        regular_file(tmp_path)
    os.mkfifo(tmp_path / "pipe")
    for odd in (tmp_path / "pipe", "/dev/zero", "/proc/self/environ"):
        with pytest.raises(InputError, match="not a regular file"):
            regular_file(odd)
    with pytest.raises(InputError, match="file not found"):
        regular_file(tmp_path / "missing.csv")


def test_text_has_no_nul_and_quotes_are_short(tmp_path):
    binary = tmp_path / "x.csv"
    binary.write_bytes(b"frame,x,y\n\x00\x01")
    with pytest.raises(InputError, match="NUL bytes"):
        read_text_file(binary)
    assert quote("x" * 500).endswith("'...") and len(quote("x" * 500)) < 70


def test_a_track_reader_refuses_devices_binary_files_and_far_frames(tmp_path):
    for path in ("/dev/zero", "/proc/self/environ"):
        with pytest.raises(TrackInputError, match="not a regular file"):
            read_track(path)
    far = tmp_path / "track.csv"
    far.write_text("frame,x,y\n0,1,2\n1000000000000,1,2\n")
    with pytest.raises(TrackInputError, match=r"track.csv:3: column 'frame': expected .*\(at most 100000000\)"):
        read_track(far)
    header = tmp_path / "long.csv"
    header.write_text("a" * 5000 + "\n")
    with pytest.raises(TrackInputError) as error:
        read_track(header)
    assert len(str(error.value)) < 300
