"""Readers of drone, robot, survey and camera logs against a known trajectory, written as the devices write them."""

from __future__ import annotations

import calendar
import datetime as dt
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from data_fixtures.gps_logs import log_fixes, walk_trajectory
from data_fixtures.target_logs import (
    UNDULATION_M,
    gpmf_payload,
    write_airdata_csv,
    write_dataflash,
    write_kml_track,
    write_rtklib_pos,
    write_tlog,
    write_tum,
    write_ulog,
)
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu
from tlsync_pipeline.ingest import FORMATS, IngestParams, detect_format, ingest, read_log, rtklib
from tlsync_pipeline.ingest.gopro import gopro_records
from tlsync_pipeline.ingest.gps_time import gpst_to_utc, leap_seconds, week_tow_to_utc

ORIGIN = Origin(47.3769, 8.5417, 450.0)
START = dt.datetime(2026, 3, 1, 12, 0, 0, 250000, tzinfo=dt.timezone.utc)
DATA = Path(__file__).parent / "data"
T2017 = calendar.timegm((2017, 1, 1, 0, 0, 0))


@pytest.fixture(scope="module")
def truth():
    """(t POSIX UTC, lat/lon/h ellipsoidal, ENU metres at ORIGIN) of a 20 s walk at 5 Hz."""
    walk = walk_trajectory(seconds=20.0, rate=5.0, gap=None)
    t, geo = log_fixes(walk, ORIGIN, START)
    return t, geo, geodetic_to_enu(geo[:, 0], geo[:, 1], geo[:, 2], ORIGIN)


def _enu(records, offset_m=0.0):
    """The records' fixes in ENU at ORIGIN (heights shifted by offset_m)."""
    v = records.values
    return geodetic_to_enu(v[:, 0], v[:, 1], v[:, 2] + offset_m, ORIGIN)


def _close(records, truth, rows=slice(None), horizontal=0.02, vertical=0.02, seconds=0.002, offset_m=0.0):
    t, _, enu = truth
    got = _enu(records, offset_m)
    assert np.abs(records.t - t[rows]).max() <= seconds
    assert np.linalg.norm(got[:, :2] - enu[rows, :2], axis=1).max() <= horizontal
    assert np.abs(got[:, 2] - enu[rows, 2]).max() <= vertical


def test_gps_time_leap_second_table():
    assert leap_seconds(T2017 + 18) == 18 and leap_seconds(T2017 + 16.5) == 17
    assert leap_seconds(calendar.timegm((2016, 6, 1, 0, 0, 0))) == 17
    assert leap_seconds(calendar.timegm((2013, 1, 1, 0, 0, 0))) == 16
    assert leap_seconds(calendar.timegm((1980, 1, 6, 0, 0, 0))) == 0
    assert gpst_to_utc(T2017 + 18) == T2017 and gpst_to_utc(T2017 + 16) == T2017 - 1
    # RTKLIB's header "2019/02/19 14:37:08.0 GPST (week2041 225428.0s)": 18 s ahead of UTC.
    assert week_tow_to_utc(2041, 225428.0) == calendar.timegm((2019, 2, 19, 14, 36, 50))
    # 2016: 17 s.
    assert week_tow_to_utc(1877, 0.0) == calendar.timegm((2015, 12, 27, 0, 0, 0)) - 17


def test_detection_by_content_not_name(tmp_path, truth):
    t, geo, enu = truth
    written = {
        "ulog": write_ulog(tmp_path / "a.csv", t, geo),
        "dataflash": write_dataflash(tmp_path / "b.csv", t, geo),
        "tlog": write_tlog(tmp_path / "c.txt", t, geo),
        "rtklib": write_rtklib_pos(tmp_path / "d.gpx", t, geo),
        "kml": write_kml_track(tmp_path / "e.gpx", t, geo),
        "tum": write_tum(tmp_path / "f.csv", t, enu),
        "dji": write_airdata_csv(tmp_path / "g.txt", t, geo),
    }
    for fmt, path in written.items():
        assert detect_format(path) == fmt, path
    headerless = write_rtklib_pos(tmp_path / "h.txt", t, geo, layout="week", header=False)
    assert detect_format(headerless) == "rtklib"
    assert b"Type,Length,Name,Format,Columns" in written["dataflash"].read_bytes()  # the text that fooled the CSV test


def test_unknown_binary_is_named_by_its_bytes_not_echoed(tmp_path):
    path = tmp_path / "x.log"
    path.write_bytes(b"\x01\x02GARBAGE\xff\xfe\x00time,lat,lon\n" * 20)
    with pytest.raises(InputError) as err:
        detect_format(path)
    message = str(err.value)
    assert (
        "binary file starting with bytes 01 02 47 41" in message
        and "GARBAGE" not in message
        and "\ufffd" not in message
    )


def test_ulog_utc_boot_clock_and_fix_type(tmp_path, truth):
    t, geo, _ = truth
    fix = np.full(len(t), 3)
    fix[:4] = 2
    records = read_log(write_ulog(tmp_path / "log.ulg", t, geo, fix_type=fix, eph=np.linspace(0.5, 2.0, len(t))))
    assert records.format == "ulog" and records.altitude == "ellipsoid" and records.utc
    assert records.dropped == {"fix_type < 3 (no 3D fix)": [1, 2, 3, 4]}
    _close(records, truth, slice(4, None), seconds=1e-6)
    np.testing.assert_allclose(records.sigma, np.linspace(0.5, 2.0, len(t))[4:], rtol=1e-6)
    assert set(records.quality) >= {"eph", "epv", "fix_type", "satellites_used"}
    boot = read_log(write_ulog(tmp_path / "boot.ulg", t, geo, boot_offset_s=250.0, utc=False))
    assert not boot.utc and "boot clock" in boot.clock
    np.testing.assert_allclose(boot.t, t - t[0] + 250.0, atol=1e-6)
    _, report = ingest(boot)
    assert report.t0_utc is None and "offsets work, UTC does not" in report.summary()


def test_dataflash_week_leap_seconds_undulation(tmp_path, truth):
    t, geo, _ = truth
    status = np.full(len(t), 6)
    status[5] = 1
    records = read_log(write_dataflash(tmp_path / "00000012.BIN", t, geo, status=status, week_zero_first=3))
    assert records.format == "dataflash" and records.utc and records.altitude == "ellipsoid"
    assert records.dropped == {"Status < 3 (no 3D fix)": [6], "GPS week 0 (no UTC yet)": [1, 2, 3]}
    rows = np.r_[3:5, 6 : len(t)]
    _close(records, truth, rows, seconds=0.0011)
    np.testing.assert_allclose(records.sigma, 0.02, rtol=1e-6)
    msl = read_log(write_dataflash(tmp_path / "nogpa.bin", t, geo, gpa=False))
    assert msl.altitude == "msl"
    _close(msl, truth, seconds=0.0011, offset_m=UNDULATION_M)
    _, report = ingest(msl, IngestParams(origin=ORIGIN))
    assert any("above mean sea level (MSL)" in w and "altitude_offset_m" in w for w in report.warnings)
    _, fixed = ingest(msl, IngestParams(origin=ORIGIN, altitude_offset_m=UNDULATION_M))
    assert not any("altitude_offset_m" in w for w in fixed.warnings) and fixed.altitude["offset_m"] == UNDULATION_M


def test_tlog_fix_times_not_receive_times_across_a_reboot(tmp_path, truth):
    t, geo, _ = truth
    records = read_log(write_tlog(tmp_path / "flight.tlog", t, geo, latency_s=0.35, reboot_at=40))
    assert records.format == "tlog" and records.altitude == "ellipsoid"
    _close(records, truth, seconds=0.002)
    assert any("rebooted 1 time" in w for w in records.warnings)
    np.testing.assert_allclose(records.sigma, 0.02)
    with_gcs = read_log(write_tlog(tmp_path / "gcs.tlog", t, geo, ground_station=True))
    _close(with_gcs, truth, seconds=0.002)  # the ground station's SYSTEM_TIME (its own clocks) is not the autopilot's


@pytest.mark.parametrize("layout", ["calendar", "week"])
@pytest.mark.parametrize("system", ["GPST", "UTC"])
def test_rtklib_layouts_time_systems_and_quality(tmp_path, truth, layout, system):
    t, geo, _ = truth
    q = np.ones(len(t), dtype=int)
    q[10:20] = 2
    q[3] = 0
    sdn = np.where(q == 2, 0.3, 0.01)
    records = read_log(write_rtklib_pos(tmp_path / "sol.pos", t, geo, layout=layout, system=system, q=q, sdn=sdn))
    keep = q > 0
    assert records.dropped == {"Q 0 (no solution)": [3 + 3 + 1]}  # 3 header lines, then the 4th fix
    _close(records, truth, keep, seconds=0.0006)
    np.testing.assert_allclose(records.sigma, sdn[keep], atol=1e-4)
    np.testing.assert_array_equal(records.quality["Q"], q[keep])
    trajectory, report = ingest(records, IngestParams(origin=ORIGIN))
    assert trajectory.sigma is not None and report.sigma_m["max"] == pytest.approx(0.3, abs=1e-3)


def test_rtklib_headerless_week_tow_and_geodetic_heights(tmp_path, truth):
    t, geo, _ = truth
    records = read_log(write_rtklib_pos(tmp_path / "a.pos", t, geo, layout="week", header=False))
    _close(records, truth, seconds=0.0006)
    geodetic = read_log(write_rtklib_pos(tmp_path / "b.pos", t, geo, geodetic=True))
    assert geodetic.altitude == "msl"
    _close(geodetic, truth, seconds=0.0006, offset_m=UNDULATION_M)


def test_kml_track_with_msl_heights(tmp_path, truth):
    t, geo, _ = truth
    records = read_log(write_kml_track(tmp_path / "track.kml", t, geo))
    assert records.format == "kml" and records.altitude == "msl"
    _close(records, truth, seconds=0.0006, offset_m=UNDULATION_M)
    relative = read_log(write_kml_track(tmp_path / "rel.kml", t, geo, altitude_mode="relativeToGround"))
    assert any("relativeToGround" in w for w in relative.warnings)


def test_kml_linestring_with_timespan_and_points(tmp_path):
    path = tmp_path / "line.kml"
    path.write_text("""<?xml version="1.0"?><kml xmlns="http://www.opengis.net/kml/2.2"><Document>
<Placemark><TimeSpan><begin>2026-03-01T12:00:00Z</begin><end>2026-03-01T12:00:30Z</end></TimeSpan>
<LineString><altitudeMode>absolute</altitudeMode><coordinates>8.5417,47.3769,400 8.5417,47.3778,400 8.5417,47.3796,400</coordinates></LineString></Placemark>
<Placemark><TimeStamp><when>2026-03-01T12:00:40Z</when></TimeStamp><Point><altitudeMode>absolute</altitudeMode><coordinates>8.5417,47.3800,400</coordinates></Point></Placemark>
</Document></kml>""")
    records = read_log(path)
    start = calendar.timegm((2026, 3, 1, 12, 0, 0))
    np.testing.assert_allclose(records.t - start, [0.0, 10.0, 30.0, 40.0], atol=0.05)
    assert any("constant speed" in w for w in records.warnings)


def test_kml_entities_are_refused(tmp_path):
    path = tmp_path / "bomb.kml"
    path.write_text(
        '<?xml version="1.0"?><!DOCTYPE kml [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;">]>'
        '<kml xmlns="http://www.opengis.net/kml/2.2"><Document><name>&b;</name></Document></kml>'
    )
    assert detect_format(path) == "kml"
    with pytest.raises(InputError, match="declares entities"):
        read_log(path)


def test_tum_local_metres_never_recentred(tmp_path, truth):
    t, _, enu = truth
    xyz = enu + [1000.0, -2000.0, 30.0]
    records = read_log(write_tum(tmp_path / "groundtruth.txt", t, xyz))
    assert records.frame == "local" and not records.utc
    trajectory, report = ingest(records)
    np.testing.assert_allclose(trajectory.xyz[0], xyz[0], atol=1e-4)
    np.testing.assert_allclose(trajectory.xyz[-1], xyz[-1], atol=1e-4)
    assert report.t0_utc is None


def test_dji_feet_whole_second_utc_no_fix_rows_and_a_pause(tmp_path, truth):
    t, geo, _ = truth
    records = read_log(write_airdata_csv(tmp_path / "airdata.csv", t, geo, no_fix_rows=5, jitter_seed=3))
    assert records.format == "dji" and records.altitude == "msl"
    assert records.dropped == {"latitude and longitude 0 (no fix yet)": [2, 3, 4, 5, 6]}
    _close(records, truth, seconds=0.15, offset_m=UNDULATION_M)
    paused = read_log(write_airdata_csv(tmp_path / "paused.csv", t, geo, jitter_seed=4, pause=(50, 7.0)))
    assert any("2 recording runs" in w for w in paused.warnings)
    _close(paused, truth, seconds=0.15, offset_m=UNDULATION_M)


def test_dji_airdata_datetime_with_milliseconds_is_each_rows_utc(tmp_path, truth):
    """An export whose datetime(utc) has milliseconds: UTC from them (the median offset per run), not from the
    whole-second anchoring, which would put every fix about half a second late."""
    t, geo, _ = truth
    whole = write_airdata_csv(tmp_path / "whole.csv", t, geo, no_fix_rows=0)
    lines = whole.read_text().splitlines()
    precise = [lines[0]]
    for line, ti in zip(lines[1:], t):
        fields = line.split(",")
        fields[1] = dt.datetime.fromtimestamp(round(ti, 3), dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]
        precise.append(",".join(fields))
    path = tmp_path / "ms.csv"
    path.write_text("\n".join(precise) + "\n")
    records = read_log(path)
    assert np.abs(records.t - t).max() < 0.002
    assert any("milliseconds" in note for note in records.notes)


def test_gopro_gpmf_payloads(truth):
    t, geo, _ = truth
    packets = []
    for k in range(0, len(t) - 5 + 1, 5):  # 1 s packets of 5 samples, video time 0.5 s behind
        chunk = geo[k : k + 5]
        packets.append((t[k] - t[0] + 0.5, 1.0, gpmf_payload(chunk, t[k], fix=0 if k == 10 else 3)))
    records = gopro_records(Path("clip.mp4"), packets)
    keep = np.ones(len(t), dtype=bool)
    keep[10:15] = False
    assert records.dropped == {"no fix (GPSF or GPS9 fix < 2)": list(range(11, 16))} and records.altitude == "ellipsoid"
    _close(records, truth, np.flatnonzero(keep)[: len(records)], seconds=0.002)
    msl = gopro_records(Path("clip.mp4"), [(0.0, 1.0, gpmf_payload(geo[:5], t[0], msl=True))])
    assert msl.altitude == "msl" and msl.quality["dop"][0] == pytest.approx(1.5)


def test_gopro_without_gps_says_so():
    from data_fixtures.target_logs import gpmf_klv

    name = gpmf_klv(b"STNM", "c", 1, b"Accelerometer", 13)
    strm = gpmf_klv(b"STRM", "", 1, name, len(name))
    with pytest.raises(InputError, match="clip.mp4: the GPMF track has no GPS5/GPS9 stream"):
        gopro_records(Path("clip.mp4"), [(0.0, 1.0, gpmf_klv(b"DEVC", "", 1, strm, len(strm)))])


def test_gopro_payload_cut_short_is_named(truth):
    _, geo, _ = truth
    payload = gpmf_payload(geo[:5], 1.7e9)
    with pytest.raises(InputError, match=r"clip.mp4: GPMF packet 1 \(at 0.000 s\): byte \d+: item b'DEVC'"):
        gopro_records(Path("clip.mp4"), [(0.0, 1.0, payload[:-30])])


def test_fit_real_file_matches_fitdecode():
    import fitdecode

    expected = []
    with fitdecode.FitReader(str(DATA / "garmin-fenix-5-bike.fit")) as reader:
        for frame in reader:
            if (
                isinstance(frame, fitdecode.FitDataMessage)
                and frame.name == "record"
                and frame.get_value("position_lat", fallback=None) is not None
            ):
                expected.append(
                    (
                        frame.get_value("timestamp").timestamp(),
                        frame.get_value("position_lat") * 180 / 2**31,
                        frame.get_value("position_long") * 180 / 2**31,
                    )
                )
    records = read_log(DATA / "garmin-fenix-5-bike.fit")
    assert records.format == "fit" and records.utc and records.altitude == "msl" and len(records) == len(expected) > 10
    np.testing.assert_allclose(records.t, [e[0] for e in expected])
    np.testing.assert_allclose(records.values[:, :2], [e[1:] for e in expected], atol=1e-9)


def test_format_choices_come_from_the_registry(tmp_path, truth):
    t, geo, _ = truth
    assert {"ulog", "dataflash", "tlog", "rtklib", "fit", "dji", "gopro", "kml", "tum"} <= set(FORMATS)
    log = write_rtklib_pos(tmp_path / "sol.txt", t, geo)
    out = tmp_path / "traj.csv"
    result = CliRunner().invoke(main, ["ingest-log", str(log), "--format", "rtklib", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_text().splitlines()[0] == "t,x,y,z,sigma"
    wrong = CliRunner().invoke(main, ["ingest-log", str(log), "--format", "ulog", "--out", str(out)])
    assert wrong.exit_code == 2 and "sol.txt" in wrong.output and "ULog" in wrong.output


def test_rtklib_real_solution_fix_and_float():
    """A real RTKLIB kinematic solution (MatRTKLIB's example, cut): GPST to UTC, Q and sigmas
    kept, floats weigh less.
    """
    path = DATA / "rover_1Hz_rtk_head.pos"
    records = read_log(path)
    solutions = [line for line in path.read_text().splitlines() if not line.startswith("%")]
    assert records.format == "rtklib" and records.altitude == "ellipsoid" and len(records) == len(solutions) == 128
    # first line: 2023/07/11 06:04:32.000 GPST = 06:04:14 UTC (18 leap seconds)
    assert records.t[0] == calendar.timegm((2023, 7, 11, 6, 4, 14))
    np.testing.assert_allclose(records.values[0], [35.165360854, 136.881409534, 41.4069])
    q = records.quality["Q"]
    assert set(np.unique(q)) == {1.0, 2.0}
    assert np.median(records.sigma[q == 2]) > 3 * np.median(records.sigma[q == 1])
    trajectory, report = ingest(records)
    assert trajectory.sigma is not None and any("fix" in w and "float" in w for w in report.warnings)


def test_fit_device_clock_through_timestamp_correlation(tmp_path):
    from data_fixtures.target_logs import write_fit_device_clock

    power_on = calendar.timegm((2026, 3, 1, 11, 58, 0)) + 0.25
    walk = walk_trajectory(seconds=30.0, rate=1.0, gap=None)
    t, geo = log_fixes(walk, ORIGIN, power_on + 100.0)
    records = read_log(write_fit_device_clock(tmp_path / "camera.fit", t, geo, power_on))
    assert records.format == "fit" and records.utc and not records.warnings[1:]
    assert any("timestamp_correlation" in n for n in records.notes)
    np.testing.assert_allclose(
        records.t, t, atol=1e-3
    )  # the correlation's fraction reaches the whole-second device times
    enu = geodetic_to_enu(geo[:, 0], geo[:, 1], geo[:, 2], ORIGIN)
    got = _enu(records, UNDULATION_M)
    assert np.linalg.norm(got[:, :2] - enu[:, :2], axis=1).max() < 0.02 and np.abs(got[:, 2] - enu[:, 2]).max() < 0.2
    alone = read_log(write_fit_device_clock(tmp_path / "alone.fit", t, geo, power_on, correlation=False))
    assert not alone.utc and "device clock" in alone.clock
    np.testing.assert_allclose(alone.t, np.round(t - power_on), atol=1e-9)


def test_gopro_gps9_per_sample_utc(truth):
    from data_fixtures.target_logs import gpmf_gps9_payload

    t, geo, _ = truth
    fix = np.full(len(t), 3)
    fix[7] = 0
    packets = [
        (k / 5.0, 1.0, gpmf_gps9_payload(t[k : k + 5], geo[k : k + 5], fix[k : k + 5])) for k in range(0, 100, 5)
    ]
    records = gopro_records(Path("hero12.mp4"), packets)
    keep = np.flatnonzero(fix[:100] >= 2)
    assert records.utc and records.dropped == {"no fix (GPSF or GPS9 fix < 2)": [8]}
    _close(records, truth, keep, seconds=0.0006)
    assert records.quality["dop"][0] == pytest.approx(1.2)


def test_nmea_hdop_fix_quality_and_gst_sigma(tmp_path, truth):
    from functools import reduce
    from operator import xor

    from data_fixtures.gps_logs import write_nmea_log

    t, geo, _ = truth
    walk = walk_trajectory(seconds=20.0, rate=5.0, gap=None)
    lines = write_nmea_log(tmp_path / "a.nmea", walk, ORIGIN, START).read_text().splitlines()
    out = []
    for line in lines:
        out.append(line)
        if line[3:6] == "GGA":
            when = line.split(",")[1]
            error = 0.5 if when.startswith("12000") else 0.02  # the first 10 s noisy
            body = f"GPGST,{when},0.3,{error:.3f},{error:.3f},0.0,{error:.3f},{error:.3f},{2 * error:.3f}"
            out.append(f"${body}*{reduce(xor, body.encode()):02X}")
    path = tmp_path / "gst.nmea"
    path.write_text("\r\n".join(out) + "\r\n")
    records = read_log(path)
    assert set(records.quality) == {"quality", "hdop"} and np.all(records.quality["quality"] == 1)
    expected = np.where(records.t - calendar.timegm((2026, 3, 1, 12, 0, 10)) < 0, 0.5, 0.02)
    np.testing.assert_allclose(records.sigma, expected)
    trajectory, report = ingest(records)
    assert report.sigma_m["max"] == pytest.approx(0.5) and report.quality["hdop"]["median"] > 0


def test_project_altitude_keys_reach_the_ingest(tmp_path, truth):
    import json

    t, geo, _ = truth
    write_kml_track(tmp_path / "track.kml", t, geo)
    origin = f"[{ORIGIN.lat}, {ORIGIN.lon}, {ORIGIN.alt}]"
    (tmp_path / "p.toml").write_text(
        f'[target]\nlog = "track.kml"\nformat = "kml"\norigin = {origin}\naltitude_offset_m = '
        f'{UNDULATION_M}\n\n[[cameras]]\nname = "c0"\n'
    )
    result = CliRunner().invoke(main, ["ingest", str(tmp_path / "p.toml"), "--work", str(tmp_path / "work")])
    assert result.exit_code == 0, result.output
    assert "heights: above mean sea level (MSL) (as the log says, offset +47.250 m)" in result.output
    report = json.loads(next((tmp_path / "work").rglob("ingest_report.json")).read_text())
    assert report["altitude"] == {"reference": "msl", "source": "log", "offset_m": UNDULATION_M}
    assert not any("altitude_offset_m" in w for w in report["warnings"])
    (tmp_path / "p.toml").write_text(
        '[target]\nlog = "track.kml"\naltitude_reference = "geoid"\n\n[[cameras]]\nname = "c0"\n'
    )
    bad = CliRunner().invoke(main, ["ingest", str(tmp_path / "p.toml")])
    assert bad.exit_code == 2 and "unknown altitude reference 'geoid'" in bad.output


def test_dji_osd_layout_app_clock_feet_and_no_gps_rows(tmp_path):
    """The TXTlogToCSVtool / CsvView layout: OSD.* columns, the app's local clock (sometimes without a fraction)."""
    path = tmp_path / "DJIFlightRecord.csv"
    rows = [
        "CUSTOM.updateTime,OSD.latitude,OSD.longitude,OSD.height [ft],OSD.isGPSused,OSD.gpsNum,OSD.gpsLevel",
        "2018/07/04 09:19:31.500,0,0,0,False,0,0",
        "2018/07/04 09:19:31.600,55.5071580,10.7170780,0.0,False,4,1",
        "2018/07/04 09:19:31.700,55.5071580,10.7170780,0.0,True,13,4",
        "2018/07/04 09:19:31.800,55.5071590,10.7170790,3.3,True,13,4",
        "2018/07/04 09:19:31.900,55.5071600,10.7170800,6.6,True,13,4",
        "2018/07/04 09:19:32,55.5071610,10.7170810,9.9,True,14,5",
        "2018/07/04 09:19:32.100,55.5071620,10.7170820,13.2,True,14,5",
    ]
    path.write_text("\n".join(rows) + "\n", encoding="latin-1")
    assert detect_format(path) == "dji"
    records = read_log(path)
    assert not records.utc and "local clock" in records.clock and records.altitude == "takeoff"
    assert records.dropped == {"GPS not used (OSD.isGPSused False, or latitude and longitude 0)": [2, 3]}
    start = calendar.timegm((2018, 7, 4, 9, 19, 31))
    np.testing.assert_allclose(records.t - start, [0.7, 0.8, 0.9, 1.0, 1.1], atol=1e-6)
    np.testing.assert_allclose(records.values[:, 2], np.arange(5) * 3.3 * 0.3048, atol=1e-9)
    np.testing.assert_array_equal(records.quality["osd.gpsnum"], [13, 13, 13, 14, 14])
    _, report = ingest(records)
    assert "offsets work, UTC does not" in report.summary()


def test_kml_my_tracks_layout_markers_and_accuracy(tmp_path):
    """As Google My Tracks writes: start/end Point markers beside a gx:MultiTrack, per-point accuracy."""
    path = tmp_path / "mytracks.kml"
    path.write_text("""<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns:gx="http://www.google.com/kml/ext/2.2" xmlns="http://www.opengis.net/kml/2.2"><Document>
<Placemark><name>(Start)</name><TimeStamp><when>2015-10-20T23:53:59.609Z</when></TimeStamp><Point><coordinates>-111.891225,40.763656,1405.0</coordinates></Point></Placemark>
<Placemark id="tour"><gx:MultiTrack><altitudeMode>absolute</altitudeMode><gx:Track>
<when>2015-10-20T23:53:59.609Z</when><gx:coord>-111.891225 40.763656 1405.0</gx:coord>
<when>2015-10-20T23:54:00.609Z</when><gx:coord>-111.891200 40.763660 1405.5</gx:coord>
<when>2015-10-20T23:54:01.639Z</when><gx:coord>-111.891052 40.763578 1412.0</gx:coord>
<ExtendedData><SchemaData schemaUrl="#schema"><gx:SimpleArrayData name="accuracy"><gx:value>26.0</gx:value><gx:value>12.0</gx:value><gx:value>4.0</gx:value></gx:SimpleArrayData></SchemaData></ExtendedData>
</gx:Track></gx:MultiTrack></Placemark>
<Placemark><name>(End)</name><TimeStamp><when>2015-10-21T00:21:31.587Z</when></TimeStamp><Point><coordinates>-111.891052 40.763578 1412.0</coordinates></Point></Placemark>
</Document></kml>""")
    records = read_log(path)
    assert len(records) == 3 and records.ignored == 2 and any("markers" in w for w in records.warnings)
    np.testing.assert_allclose(records.sigma, [26.0, 12.0, 4.0])
    np.testing.assert_allclose(records.t[-1] - records.t[0], 2.03, atol=1e-6)


def _same_records(a, b):
    assert (a.dropped, a.ignored, a.warnings, a.altitude) == (b.dropped, b.ignored, b.warnings, b.altitude)
    for name in ("t", "values", "line", "sigma"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.quality.keys() == b.quality.keys()
    for name in a.quality:
        np.testing.assert_array_equal(a.quality[name], b.quality[name])


@pytest.mark.parametrize("layout", ["calendar", "week"])
@pytest.mark.parametrize("system", ["GPST", "UTC"])
def test_rtklib_read_at_once_as_line_by_line(tmp_path, truth, layout, system, monkeypatch):
    """NumPy's parse of alike solution lines gives the line-by-line reading's records, bit for bit; a file with
    one odd line (a Q written 1.0, a comma, a cut line) goes line by line whole."""
    t, geo, _ = truth
    q = np.where(np.arange(len(t)) % 17 == 3, 0, 1 + (np.arange(len(t)) % 5 == 0))
    path = write_rtklib_pos(tmp_path / "sol.pos", t, geo, layout=layout, system=system, q=q, sdn=0.01 + q * 0.1)
    real = DATA / "rover_1Hz_rtk_head.pos"
    lines = path.read_text().splitlines()
    odd = tmp_path / "odd.pos"
    odd.write_text("\n".join([*lines[:20], lines[20].replace(" 1 ", " 1.0 ", 1), *lines[21:-1], lines[-1][:30]]))
    at_once = [read_log(p) for p in (path, real, odd)]
    calls = []
    original = rtklib._solutions_at_once
    monkeypatch.setattr(rtklib, "_solutions_at_once", lambda *a: calls.append(original(*a)) or None)
    by_line = [read_log(p) for p in (path, real, odd)]
    assert [c is not None for c in calls] == [True, True, False]
    for a, b in zip(at_once, by_line):
        _same_records(a, b)
    assert len(at_once[2].dropped["malformed line"]) == 2
