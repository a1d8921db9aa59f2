"""DJI SRT subtitles: real samples of eight firmware layouts against DJI_SRT_Parser's reading of them, the lat/lon
order decided and stated, local wall clocks with and without [target] utc_offset, clips joined, precision as sigma."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest

from data_fixtures.gps_logs import log_fixes, walk_trajectory
from data_fixtures.target_logs import SRT_LAYOUTS, UNDULATION_M, write_dji_srt
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu
from tlsync_pipeline.ingest import detect_format, ingest, read_log

DATA = Path(__file__).parent / "data" / "dji_srt"
ORIGIN = Origin(47.3769, 8.5417, 450.0)

# DJI_SRT_Parser 1.3.10 (smoothing off) on these files: fixes, first and last (subtitle time, UTC ms by its
# tz-lookup, lat, lon, height); the time zone it found; what decides the order here.
REFERENCE = {
    "MAVIC3.srt": (
        50,
        ("00:00:00,000", 1640435272373, 3.41531, -3.3744, 0.401),
        ("00:00:00,980", 1640435273350, 3.41531, -3.3744, 0.401),
        0,
        "labelled",
    ),
    "air2s.srt": (
        17,
        ("00:00:00,000", 1659872440774, 41.424724, 2.234156, 117),
        ("00:00:00,533", 1659872441308, 41.42473, 2.234102, 117.1),
        2,
        "labelled",
    ),
    "matrice_300.srt": (
        60,
        ("00:00:00,000", 1655820377000, 36.6146, -6.112, 0.3),
        ("00:00:59,000", 1655820436000, 36.6153, -6.113, 83.8),
        2,
        "layout GPS(lat, lon, altitude)",
    ),
    "mavic_2_style.SRT": (
        30,
        (None, 1501906311393, -20.2533, 149.0251, None),
        (None, 1501906340393, -20.2534, 149.0253, None),
        10,
        "labelled",
    ),
    "mavic_2pro_new.SRT": (
        40,
        ("00:00:23,360", 1569590911758, -35.08135, -60.286298, None),
        ("00:00:25,000", 1569590927572, -35.081357, -60.286307, None),
        -3,
        "labelled",
    ),
    "mavic_air2.srt": (
        25,
        ("00:00:00,000", 1651410118531, 41.420684, 2.162162, 27.3),
        ("00:00:00,400", 1651410118931, 41.420686, 2.162162, 29.2),
        2,
        "labelled",
    ),
    "mavic_mini.SRT": (
        40,
        ("00:00:00,000", None, 48.0771, -121.7458, 200.7),
        ("00:00:39,000", None, 48.0773, -121.7462, 200.8),
        None,
        "beyond +-90",
    ),
    "mavic_pro.SRT": (
        40,
        ("00:00:01,000", 1501906311000, -20.2533, 149.0251, 1.9),
        ("00:00:40,000", 1501906350000, -20.2534, 149.0253, 59.2),
        10,
        "beyond +-90",
    ),
    "old_format.SRT": (
        40,
        ("00:00:01,000", 1501906311000, -20.2533, 149.0251, 1.9),
        ("00:00:40,000", 1501906350000, -20.2534, 149.0253, 59.2),
        10,
        "beyond +-90",
    ),
    "p4_rtk.SRT": (
        55,
        ("00:00:00,000", None, -34.237922, -58.851745, 85.8),
        ("00:00:54,000", None, -34.232349, -58.849196, 85.8),
        None,
        "distance to HOME",
    ),
    "p4p_sample.SRT": (
        5,
        ("00:00:00,000", None, 47.4692, 8.209, 45.6),
        ("00:00:04,000", None, 47.4692, 8.209, 45.6),
        None,
        "layout GPS(lon, lat, satellites)",
    ),
}


def _seconds(code: str) -> float:
    return int(code[:2]) * 3600 + int(code[3:5]) * 60 + int(code[6:8]) + int(code[9:12]) / 1000


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_real_srt_layouts_match_dji_srt_parser(name):
    count, first, last, zone_h, decided = REFERENCE[name]
    path = DATA / name
    assert detect_format(path) == "srt"
    records = read_log(path)
    assert records.format == "srt" and len(records) == count and not records.utc
    for i, (code, wall_ms, lat, lon, height) in ((0, first), (-1, last)):
        np.testing.assert_allclose(records.values[i, :2], [lat, lon], atol=1e-9)
        if height is not None:
            assert records.values[i, 2] == pytest.approx(height)
        if wall_ms is not None and zone_h is not None:  # the local wall clock, the reference's tz-lookup zone removed
            assert records.t[i] - zone_h * 3600 == pytest.approx(
                wall_ms / 1000, abs=0.5 if "whole seconds" in records.notes[1] else 0.001
            )
        elif code is not None:
            assert records.t[i] - records.video_time_zero == pytest.approx(_seconds(code), abs=1e-6)
    assert decided in (records.notes[0] if decided != "labelled" else "labelled") and "precision" in records.notes[-1]
    assert records.sigma is not None and np.all(records.sigma > 0)


def test_clips_joined_in_one_file_are_anchored_apart():
    records = read_log(
        DATA / "mavic_2pro_new.SRT"
    )  # blocks 518-557: a clip ends at block 537 and the next starts 14 s later
    assert any("2 runs" in w for w in records.warnings)
    step = np.diff(records.t)
    assert step.max() > 13.0 and np.median(step) == pytest.approx(0.04, abs=0.001)


def test_utc_offset_puts_the_local_wall_clock_on_utc():
    local = read_log(DATA / "mavic_pro.SRT")
    utc = read_log(DATA / "mavic_pro.SRT", utc_offset_s=10 * 3600)
    assert utc.utc and not local.utc and "drone's local" in local.clock
    np.testing.assert_allclose(utc.t, local.t - 36000)
    assert any("UTC+10:00 as given" in n for n in utc.notes)
    assert any("utc_offset is not used" in w for w in read_log(DATA / "p4p_sample.SRT", utc_offset_s=3600).warnings)
    assert any(
        "utc_offset is not used" in w
        for w in read_log(Path(__file__).parent / "data" / "garmin-fenix-5-bike.fit", utc_offset_s=3600).warnings
    )


def test_precision_becomes_the_per_fix_sigma():
    four = read_log(DATA / "mavic_pro.SRT")  # 4 decimals at 20 S: steps 11.1 m north, 10.4 m east
    six = read_log(DATA / "air2s.srt")
    assert four.sigma[0] == pytest.approx(
        np.sqrt((11.132**2 + (11.132 * np.cos(np.radians(20.2533))) ** 2) / 24), rel=1e-3
    )
    assert six.sigma.max() < 0.03 and any("4 decimals" in w for w in four.warnings)
    _, report = ingest(four)
    assert report.sigma_m["median"] == pytest.approx(four.sigma[0], rel=1e-6) and any(
        n.startswith("precision") for n in report.notes
    )


@pytest.fixture(scope="module")
def flight():
    """A 60 s walk at 1 Hz (5 Hz for the per-frame layouts), from 12:00:00.25 UTC."""
    start = dt.datetime(2026, 3, 1, 12, 0, 0, 250000, tzinfo=dt.timezone.utc)
    slow = log_fixes(walk_trajectory(seconds=60.0, rate=1.0, gap=None), ORIGIN, start)
    fast = log_fixes(walk_trajectory(seconds=20.0, rate=5.0, gap=None), ORIGIN, start)
    return slow, fast


@pytest.mark.parametrize("layout", SRT_LAYOUTS)
def test_written_layouts_give_the_trajectory_back(tmp_path, flight, layout):
    t, geo = flight[1] if layout in ("air2", "mavic3") else flight[0]
    records = read_log(write_dji_srt(tmp_path / "flight.srt", t, geo, layout, utc_offset_s=7200.0), utc_offset_s=7200.0)
    decimals = {"air2": 6, "mavic3": 5}.get(layout, 4)
    step = 111_320 * 10.0**-decimals
    got = geodetic_to_enu(records.values[:, 0], records.values[:, 1], records.values[:, 2], ORIGIN)
    enu = geodetic_to_enu(geo[:, 0], geo[:, 1], geo[:, 2], ORIGIN)
    assert (
        np.abs(got[:, :2] - enu[:, :2]).max() <= step / 2 + 1e-3
    )  # the rounding of the printed coordinates, nothing more
    if layout == "p4p":  # no date: the video's timeline
        assert not records.utc and np.allclose(records.t, t - t[0])
    else:
        assert records.utc
        error = records.t - t
        assert np.ptp(error) < 1e-3 and abs(error[0]) <= (0.0011 if layout in ("air2", "mavic3") else 0.5)
    if layout in ("air2", "mavic3"):
        assert records.altitude == "msl" and np.abs(records.values[:, 2] - (geo[:, 2] - UNDULATION_M)).max() < 0.002


def test_lat_lon_order_evidence_and_conflicts(tmp_path, flight):
    (t, geo), _ = flight
    # both values within 90 degrees and no HOME block: the speeds the file states (H.S) decide for (lon, lat)
    records = read_log(write_dji_srt(tmp_path / "p4p.srt", t, geo, "p4p", decimals=6))
    assert "(longitude, latitude)" in records.notes[0] and "H.S" in records.notes[0] and not records.warnings
    # an M300-style file whose values were written (lon, lat): the layout says (lat, lon); nothing else in the file
    # decides
    swapped = write_dji_srt(tmp_path / "m300.srt", t, geo[:, [1, 0, 2]], "m300")
    read = read_log(swapped)
    assert "(latitude, longitude)" in read.notes[0] and "layout" in read.notes[0]
    np.testing.assert_allclose(read.values[0, :2], np.round(geo[0, [1, 0]], 4))


def test_blocks_without_a_position_are_counted_and_a_file_without_any_is_refused(tmp_path):
    path = tmp_path / "nogps.srt"
    path.write_text(
        '1\n00:00:00,000 --> 00:00:00,033\n<font size="36">SrtCnt : 1, DiffTime : 33ms\n2022-08-07 13:40:40,774,808\n'
        "[iso : 100] [shutter : 1/80.0] [fnum : 280] </font>\n",
        encoding="utf-8",
    )
    with pytest.raises(InputError, match="nogps.srt: no position fix in the subtitle blocks"):
        read_log(path)
    mixed = tmp_path / "mixed.srt"
    mixed.write_text(
        (DATA / "p4p_sample.SRT").read_text().replace("GPS (8.2090, 47.4692, 18)", "GPS (0.0, 0.0, 0)", 1),
        encoding="utf-8",
    )
    records = read_log(mixed)
    assert len(records) == 4 and records.dropped == {"no position (n/a, or latitude and longitude 0)": [1]}


def test_a_file_mixing_layouts_reads_each_block_by_its_own():
    """DJI_SRT_Parser's mixed sample: P4 RTK blocks (GPS (lon, lat, sats)) then Mavic 2 Pro blocks (labelled)."""
    records = read_log(DATA / "mix_p4rtk_mavic2pro.srt")
    assert (
        len(records) == 12
        and np.abs(records.values[:, 0] + 34.65).max() < 0.01
        and np.abs(records.values[:, 1] + 59.41).max() < 0.01
    )
    assert any("labelled" in n for n in records.notes) and any("(longitude, latitude)" in n for n in records.notes)
    assert any("have no date" in w for w in records.warnings) and not records.utc
    heights = records.values[:, 2]
    assert np.allclose(heights[:6], [17.39, 17.33, 17.22, 17.16, 17.31, 17.38])  # H .. m of the P4 RTK blocks
    assert np.allclose(
        heights[6:], [120.061, 120.099, 120.099, 120.099, 120.141, 120.141]
    )  # [altitude: ..] of the Mavic 2 Pro blocks
    assert any("different references" in w for w in records.warnings)


def _per_frame_srt(path: Path, speed_mps: float, spike_at: int | None = None) -> None:
    """A Mavic 3-like file: blocks at 50 fps, the receiver's fix updated at 10 Hz (held over 5 frames), 5 decimals."""
    blocks = []
    for i in range(1500):
        t_fix = (i // 5) * 0.1
        north = speed_mps * t_fix + (1000.0 if i == spike_at else 0.0)
        lat, lon = 3.41531 + north / 111_320.0, -3.3744
        wall = dt.datetime(2021, 12, 25, 12, 27, 52) + dt.timedelta(seconds=i * 0.02)
        ms = i * 20
        blocks.append(
            f"{i + 1}\n00:00:{ms // 1000:02d},{ms % 1000:03d} --> "
            f"00:00:{(ms + 20) // 1000:02d},{(ms + 20) % 1000:03d}\n"
            f'<font size="28">FrameCnt: {i + 1}, DiffTime: '
            f"20ms\n{wall:%Y-%m-%d %H:%M:%S}.{wall.microsecond // 1000:03d}\n"
            f"[latitude: {lat:.5f}] [longitude: {lon:.5f}] [rel_alt: 1.0 abs_alt: 10.0]</font>\n"
        )
    path.write_text("\n".join(blocks))


def test_per_frame_fixes_held_and_rounded_are_not_spikes(tmp_path):
    """MAVIC3.srt's case: a 10 Hz fix held over 5 frames at 50 fps, 1.1 m rounding; 35 m/s is under the 60 m/s bound, so
    nothing is dropped (frame to frame the implied speed reaches 180 m/s); a 1 km jump is still a spike, with the key
    named."""
    path = tmp_path / "m3.srt"
    _per_frame_srt(path, 35.0)
    _, report = ingest(read_log(path))
    assert report.fixes_used == report.fixes_read == 1500 and not report.gaps and not report.dropped
    _per_frame_srt(path, 35.0, spike_at=702)
    _, report = ingest(read_log(path))
    assert report.fixes_used == 1499 and list(report.dropped) == ["spike (implied speed over 60 m/s)"]
    assert any("max_speed_mps" in w and "--max-speed" in w for w in report.warnings)


def test_a_local_wall_clock_start_is_printed_as_a_local_date():
    _, report = ingest(read_log(DATA / "old_format.SRT"))
    assert report.t0_utc is None and report.t0_local == "2017-08-05T14:11:51.500000"
    assert "from 2017-08-05T14:11:51.500000 local time" in report.summary()
