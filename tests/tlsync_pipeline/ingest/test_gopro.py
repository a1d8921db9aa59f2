"""GoPro GPMF sample times: gpmf-parser's sample clock (STMP or MP4 payload times), GPSU and GPS9 UTC; real HERO7 and
HERO11 payloads.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest

from data_fixtures.gps_logs import log_fixes, walk_trajectory
from data_fixtures.target_logs import gpmf_payload
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest import detect_format, ingest, read_log
from tlsync_pipeline.ingest.gopro import Payload, gopro_records, payload_times, sample_clock
from tlsync_pipeline.ingest.gpmf import gps_blocks

DATA = Path(__file__).parent / "data"
ORIGIN = Origin(33.1268, -117.3273, 10.0)
START = dt.datetime(2026, 3, 1, 12, 0, 0, tzinfo=dt.timezone.utc).timestamp()
RATE = 18.1792  # Hz: GoPro's GPS5 rate
FIRST = 0.0552  # s: the first GPS sample trails the video's first frame
PAYLOAD = 1.001  # s: GoPro's metadata payload interval


def _stream(seconds: float = 12.0, stmp: bool = True, seed: int = 0):
    """(packets, sample times on the video timeline, geodetic samples): a 5 m/s walk sampled at RATE from FIRST,
    cut into 1.001 s payloads by the time each sample was delivered (the last one ends with the video); GPSU = UTC of
    each payload's first sample,
    rounded to 10 ms and now and then one sample late, the first one stale by 1.4 s; STMP jitters by 3 ms."""
    rng = np.random.default_rng(seed)
    n = int((seconds - FIRST) * RATE)
    media = FIRST + np.arange(n) / RATE
    walk = walk_trajectory(seconds=seconds + 2, rate=50.0, gap=None)
    t_walk, geo_walk = log_fixes(walk, ORIGIN, START)
    geo = np.column_stack([np.interp(START + media, t_walk, geo_walk[:, j]) for j in range(3)])
    packets, k = [], 0
    while k * PAYLOAD < media[-1]:
        inside = np.flatnonzero((media >= k * PAYLOAD) & (media < (k + 1) * PAYLOAD))
        late = int(rng.random() < 0.3)
        gpsu = round(START + media[inside[0]] + late / RATE, 2) + (-1.4 if k == 0 else 0.0)
        stamp = int(round((media[inside[0]] + rng.normal(0, 0.003)) * 1e6)) + 5_000_000 if stmp else None
        payload = gpmf_payload(
            geo[inside],
            gpsu,
            stmp_us=stamp,
            shutter_stmp_us=5_000_000 + int(round(k * PAYLOAD * 1e6)) if stmp else None,
        )
        packets.append((k * PAYLOAD, min(PAYLOAD, seconds - k * PAYLOAD), payload))
        k += 1
    return packets, media, geo


def test_sample_clock_from_stmp_matches_the_sample_times():
    packets, media, geo = _stream(stmp=True)
    records = gopro_records(Path("hero9.mp4"), packets)
    assert records.utc and len(records) == len(media)
    video = records.t - records.video_time_zero
    assert np.abs(video - media).max() < 0.004  # STMP jitter over the file, not a payload's 55 ms
    np.testing.assert_allclose(records.values[:, :2], geo[:, :2], atol=1e-7)  # the payload's 1e-7 degree integers
    assert abs(records.video_time_zero - START) < 0.03  # GPSU: 10 ms steps, one sample late now and then
    assert any("camera STMP" in note for note in records.notes) and any("stale" in w for w in records.warnings)


def test_sample_clock_without_stmp_is_gpmf_parsers_least_squares_line():
    packets, media, _ = _stream(stmp=False)
    records = gopro_records(Path("hero7.mp4"), packets)
    ends = np.array([start + duration for start, duration, _ in packets])
    counts = np.cumsum([len(b.samples) for _, _, p in packets for b in gps_blocks(p)])
    slope, intercept = np.polyfit(ends, counts, 1)
    reference = -intercept / slope + np.arange(len(media)) / slope
    np.testing.assert_allclose(
        records.t - records.video_time_zero, reference, atol=1e-6
    )  # POSIX seconds in float64: 0.2 us
    # counting delivered samples puts the line about half a sample early (27 ms), spreading over a payload up to 55 ms
    error = reference - media
    assert np.abs(error).max() < 0.04 and -0.04 < np.median(error) < -0.015
    assert any("MP4 payload times" in note for note in records.notes)


def test_sample_clock_single_payload_and_timo():
    clock = sample_clock([Payload(2.0, 3.0, 18, timo_s=0.1)], track_start_s=2.0)
    assert clock.first_s == pytest.approx(1.9) and clock.rate_hz == pytest.approx(18.0)
    # TIMO is the last payload's, as gpmf-parser reads it
    line = sample_clock([Payload(0.0, 1.0, 18, timo_s=0.0), Payload(1.0, 2.0, 18, timo_s=0.1)], track_start_s=0.0)
    assert line.first_s == pytest.approx(-0.1) and line.rate_hz == pytest.approx(18.0)
    stamped = sample_clock(
        [Payload(0.0, 1.0, 18, 1_100_000, 1_000_000), Payload(1.0, 2.0, 18, 2_090_000, 2_000_000)], track_start_s=0.0
    )
    assert (
        stamped.method == "STMP"
        and stamped.first_s == pytest.approx(0.1)
        and stamped.rate_hz == pytest.approx(18 / 0.99)
    )
    # TSMP counts a sample the first payload's data lost: the rate counts it, as gpmf-parser's does
    counted = sample_clock(
        [Payload(0.0, 1.0, 18, 1_100_000, 1_000_000, tsmp=18), Payload(1.0, 2.0, 18, 2_090_000, 2_000_000, tsmp=37)],
        track_start_s=0.0,
    )
    assert counted.rate_hz == pytest.approx(19 / 0.99)


def test_payload_times_as_gpmf_parser_gives_them():
    """GetPayloadTime: payload k over [k, k + 1) x the base duration, the last clipped to the track's length."""
    # GoPro's table, every payload 1.001 s but a shorter last: the sample table's own times
    times = payload_times([1001] * 10 + [533], 1000.0)
    assert (
        times[0] == (0.0, 1.001) and times[9] == pytest.approx((9.009, 10.01)) and times[10][1] == pytest.approx(10.543)
    )
    # a first payload of another length moves every later payload by its share of the mean, not by its own length
    shifted = payload_times([1034, 1001, 1001, 1001], 1000.0)
    assert [round(end, 6) for _, end in shifted] == [1.00925, 2.0185, 3.02775, 4.037]


def test_real_hero7_payloads_gpsu_against_the_sample_clock():
    """17 real HERO7 Black payloads (GPS5 at 18 Hz, no STMP), placed every 1.001 s as the camera's MP4 does."""
    payloads = _payloads(DATA / "hero7_gpmf.raw")
    records = gopro_records(Path("hero7.mp4"), [(k * PAYLOAD, PAYLOAD, p) for k, p in enumerate(payloads)])
    assert (
        records.utc
        and records.altitude == "ellipsoid"
        and len(records) == sum(len(b.samples) for p in payloads for b in gps_blocks(p))
    )
    video = records.t - records.video_time_zero
    assert 18.0 < 1 / np.median(np.diff(video)) < 18.4
    assert (
        dt.datetime.fromtimestamp(records.video_time_zero, dt.timezone.utc).strftime("%Y-%m-%d %H:%M")
        == "2019-01-03 16:33"
    )
    trajectory, report = ingest(records)
    assert any("GPSU" in note for note in report.notes) and "read: " in report.summary()


def test_real_hero11_gps9_per_sample_utc_and_the_gpsu_lag():
    """Real HERO11 payloads carry GPS5 and GPS9 (10 Hz, each sample's UTC): GPS9 is read, GPS5 not twice.
    Their GPSU is not the UTC of the payload's first sample, as GoPro documents it, but 1.4 s after it."""
    payloads = _payloads(DATA / "hero11_gpmf.raw")
    records = gopro_records(Path("hero11.mp4"), [(k * PAYLOAD, PAYLOAD, p) for k, p in enumerate(payloads)])
    nine = [b for p in payloads for b in gps_blocks(p) if b.nine]
    gpsu = [b.utc for p in payloads for b in gps_blocks(p) if not b.nine]
    assert len(records) == sum(int((b.samples[:, 8] >= 2).sum()) for b in nine)
    first_of_payload = [float(946684800.0 + b.samples[0, 5] * 86400 + b.samples[0, 6]) for b in nine]
    lag = np.array(gpsu) - np.array(first_of_payload)
    assert np.abs(lag - 1.4).max() < 0.11
    assert np.all(np.diff(records.t) > 0) and abs(np.median(np.diff(records.t)) - 0.1) < 0.002
    assert any("GPS9" in note for note in records.notes)


def _payloads(path: Path) -> list[bytes]:
    """A raw GPMF stream (payloads back to back) split into its DEVC payloads."""
    from tlsync_pipeline.ingest.gpmf import klv_items

    data = path.read_bytes()
    return [
        data[offset - 8 : offset + ((size * repeat + 3) & ~3)]
        for key, _, size, repeat, offset in klv_items(data)
        if key == b"DEVC"
    ]


def test_a_raw_gpmf_stream_is_read_on_its_own_timeline(tmp_path):
    """A ``.raw`` GPMF dump (payloads back to back, starting DEVC) is detected and read: the HERO7's samples, every
    payload
    placed 1.001 s apart as the camera's MP4 would, the missing MP4 said in a warning."""
    path = tmp_path / "hero7.raw"
    path.write_bytes((DATA / "hero7_gpmf.raw").read_bytes())
    assert detect_format(path) == "gopro"
    records = read_log(path)
    placed = gopro_records(path, [(k * PAYLOAD, PAYLOAD, p) for k, p in enumerate(_payloads(path))])
    assert (
        len(records) == len(placed) > 200
        and np.array_equal(records.t, placed.t)
        and np.array_equal(records.values, placed.values)
    )
    assert any("raw GPMF" in w and "MP4" in w for w in records.warnings)
