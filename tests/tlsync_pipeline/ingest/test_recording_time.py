"""A video's recording time from its metadata: phones' QuickTime creationdate (with its zone), MP4 creation_time
(untrusted), a DJI subtitle file beside the video (only when its clock is UTC)."""

from __future__ import annotations

import calendar
import datetime as dt
from pathlib import Path

import numpy as np
import pytest

from data_fixtures.gps_logs import log_fixes, walk_trajectory
from data_fixtures.target_logs import write_dji_srt
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest.recording_time import PHONE_TOLERANCE_S, parse_utc, recording_time


def _video(path: Path, **tags: str) -> Path:
    import av

    with av.open(str(path), "w", options={"movflags": "use_metadata_tags"}) as out:
        out.metadata.update(tags)
        stream = out.add_stream("mpeg4", rate=10)
        stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
        for _ in range(3):
            for packet in stream.encode(av.VideoFrame.from_ndarray(np.zeros((48, 64, 3), np.uint8), format="rgb24")):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    return path


def test_parse_utc_needs_a_zone():
    noon = calendar.timegm((2026, 3, 1, 12, 0, 0))
    assert parse_utc("2026-03-01T13:00:00+0100") == noon
    assert parse_utc("2026-03-01T13:00:00+01:00") == noon
    assert parse_utc("2026-03-01T12:00:00.000000Z") == noon
    assert parse_utc("2026-03-01T12:00:00") is None and parse_utc("yesterday") is None


def test_phone_creationdate_is_trusted_mp4_creation_time_is_not(tmp_path):
    video = _video(
        tmp_path / "phone.mov",
        **{
            "com.apple.quicktime.creationdate": "2026-03-01T13:00:05+0100",
            "creation_time": "2026-03-01T12:00:07.000000Z",
        },
    )
    phone, container = recording_time(video)
    assert phone.source.startswith("QuickTime") and phone.trusted and phone.tolerance_s == PHONE_TOLERANCE_S
    assert phone.utc_s == calendar.timegm((2026, 3, 1, 12, 0, 5))
    assert container.source == "MP4 creation_time" and not container.trusted and container.tolerance_s is None
    assert recording_time(_video(tmp_path / "dvr.mp4")) == []  # no tags: nothing to say


def test_dji_subtitles_beside_the_video_count_only_on_utc(tmp_path):
    start = dt.datetime(2026, 3, 1, 12, 0, 0, 250000, tzinfo=dt.timezone.utc)
    t, geo = log_fixes(walk_trajectory(seconds=10.0, rate=5.0, gap=None), Origin(47.3769, 8.5417, 450.0), start)
    video = _video(tmp_path / "DJI_0001.MP4")
    write_dji_srt(tmp_path / "DJI_0001.SRT", t, geo, "mavic3", utc_offset_s=3600.0)
    assert all(not r.source.startswith("DJI") for r in recording_time(video))  # a local clock with no zone is no UTC
    dji = recording_time(video, utc_offset_s=3600.0)[0]
    assert (
        dji.source == "DJI SRT (DJI_0001.SRT)"
        and dji.trusted
        and dji.utc_s == pytest.approx(start.timestamp(), abs=0.002)
    )
    assert dji.tolerance_s == pytest.approx(0.05)


def test_unreadable_video_is_named(tmp_path):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    with pytest.raises(InputError, match="bad.mp4: cannot read the video's metadata"):
        recording_time(bad)
