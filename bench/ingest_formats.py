"""Real recorded logs read by tlsync against each format's reference reader.

For every real file found under $TLSYNC_REAL_LOGS (default /tmp/tlsync_real_logs;
where each comes from is in SOURCES, none is committed), the fixes tlsync reads
are compared with the fixes the format's own reference reader gives: both put
in ENU metres at the first reference fix with tlsync's geodesy, matched in
file order; printed: fixes compared, max horizontal and vertical difference
(m), max time difference (s). Files that are absent are skipped; with
--write the table goes into docs/ingest.md.

    python bench/ingest_formats.py [--write]

Reference readers: pyulog (ULog), pymavlink (DataFlash: DFReader's own GPS
clock; tlog: GPS_RAW_INT.time_usec + the median SYSTEM_TIME offset),
fitdecode (FIT), RTKLIB's readsolt (bench/rtklib_readpos.c, built as its
header says, path in $RTKLIB_READPOS), GoPro's gpmf-parser C demo (GPMF; build
it from the gpmf-parser sources with the printf precision of its scaled data,
payload times and computed sample rates raised to 8-9 decimals, and give its
path in $GPMF_DEMO; the sample times compared are its sample clock, first +
n / rate from the computed GPS5 sample rate), numpy.loadtxt (TUM), Python's
csv module (DJI OSD layout: a CSV has no other reader), AirData's own GPX
export of the same flight (AirData CSV: the .gpx beside the .csv), the mcap
library with mcap-ros2-support (MCAP), DJI_SRT_Parser (DJI SRT: the path of
its index.js in $DJI_SRT_PARSER, with its npm dependencies moment-timezone
and tz-lookup installed beside it; smoothing off). The GoPro time is
compared on the video timeline; the UTC anchoring (each payload's GPSU
against the one median offset) is named in the row.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench._report import write_block  # noqa: E402
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu  # noqa: E402
from tlsync_pipeline.ingest import ingest, read_log  # noqa: E402

REAL = Path(os.environ.get("TLSYNC_REAL_LOGS", "/tmp/tlsync_real_logs"))
DOC = Path(__file__).resolve().parent.parent / "docs" / "ingest.md"
SOURCES = {
    "sample_log_small.ulg": "PX4/pyulog test/sample_log_small.ulg (BSD-3-Clause)",
    "test.BIN": "ArduPilot/pymavlink tests/test.BIN (LGPL-3.0)",
    "mav.tlog": "PyFlightCoach/DroneInterface simulator/mav.tlog (LGPL-3.0; ArduPilot SITL)",
    "vtol.tlog": "ArduPilot/UAVLogViewer src/assets/vtol.tlog (GPL-3.0)",
    "activity-small-fenix2-run.fit": "polyvertex/fitdecode tests/files/activity-small-fenix2-run.fit (MIT)",
    "max-heromode.mp4": "gopro/gpmf-parser samples/max-heromode.mp4 (Apache-2.0 / MIT)",
    "freiburg1_xyz-groundtruth.txt": "MichaelGrupp/evo test/data/freiburg1_xyz-groundtruth.txt (TUM RGB-D, CC BY 4.0)",
    "georeferenced.tum": "MichaelGrupp/evo test/data/georeferenced.tum (GPL-3.0)",
    "nav2_turtlebot.mcap": "MichaelGrupp/evo test/data/nav2_turtlebot.mcap (GPL-3.0), topic /odom",
    "rover_1Hz_rtk.pos": "taroz/MatRTKLIB examples/data/kinematic/rover_1Hz_rtk.pos (MIT; 142 fix, 389 float)",
    "dvm_drone_log.csv": "egemose/DroneVideoMeasure tests/test_data/test_drone_log.csv (MIT; a DJI Phantom 4 Pro "
    "flight, OSD layout)",
    "airdata_mini2.csv": "ANG13T/DroneXtract test-data/Airdata-Files/AirdataCSV.csv, with AirdataGPX.gpx beside it as "
    "airdata_mini2.gpx (MIT; a 2-cell DJI drone, Mini 2 class, AirData layout)",
    "dji_srt_old_format.SRT": "JuanIrache/DJI_SRT_Parser samples/old_format.SRT (MIT; Phantom 3/4 layout: "
    "HOME(lon,lat) date, GPS(lon,lat,sats) Hb Hs, 1 Hz)",
    "dji_srt_mavic_pro.SRT": "JuanIrache/DJI_SRT_Parser samples/mavic_pro.SRT (MIT; Mavic Pro: HOME(lon,lat) date, "
    "GPS(lon,lat,sats) BAROMETER, 1 Hz)",
    "dji_srt_p4p_sample.SRT": "JuanIrache/DJI_SRT_Parser samples/p4p_sample.SRT (MIT; Phantom 4 Pro: F/, SS, GPS "
    "(lon, lat, sats), D, H, H.S; no date)",
    "dji_srt_mavic_mini.SRT": "JuanIrache/DJI_SRT_Parser samples/mavic_mini.SRT (MIT; Mavic Mini: GPS (lon, lat, "
    "sats), D, H; no date)",
    "dji_srt_p4_rtk.SRT": "JuanIrache/DJI_SRT_Parser samples/p4_rtk.SRT (MIT; Phantom 4 RTK: GPS (lon, lat, sats), "
    "HOME (lon, lat, alt), D, H; 6 decimals)",
    "dji_srt_mavic_2_style.SRT": "JuanIrache/DJI_SRT_Parser samples/mavic_2_style.SRT (MIT; Mavic 2 early firmware: "
    "no subtitle times, [latitude : ..] [longtitude : ..])",
    "dji_srt_m2zoom.SRT": "JuanIrache/DJI_SRT_Parser samples/m2zoom.SRT (MIT; Mavic 2 Zoom: per frame, date with ms "
    "and us, [latitude : ..] [longtitude : ..] [altitude: ..])",
    "dji_srt_mavic_2pro_new.SRT": "JuanIrache/DJI_SRT_Parser samples/mavic_2pro_new.SRT (MIT; Mavic 2 Pro: per frame, "
    "12 clips joined in one file)",
    "dji_srt_mavic_air2.srt": "JuanIrache/DJI_SRT_Parser samples/mavic_air2.srt (MIT; Air 2: per frame, [latitude: "
    "..] [longitude: ..] [altitude: ..])",
    "dji_srt_air2s.srt": "JuanIrache/DJI_SRT_Parser samples/air2s.srt (MIT; Air 2S: per frame)",
    "dji_srt_MAVIC3.srt": "JuanIrache/DJI_SRT_Parser samples/MAVIC3.srt (MIT; Mavic 3: per frame, date with ms, "
    "[rel_alt: .. abs_alt: ..]; coordinates altered by the sample's author)",
    "dji_srt_matrice_300.srt": "JuanIrache/DJI_SRT_Parser samples/matrice_300.srt (MIT; Matrice 300: "
    "GPS(lat,lon,altM) BAROMETER, 1 Hz)",
    "dji_srt_mix_p4rtk_mavic2pro.srt": "JuanIrache/DJI_SRT_Parser samples/mix_p4rtk_mavic2pro.srt (MIT; P4 RTK blocks "
    "with H .. m, then Mavic 2 Pro blocks with [altitude: ..], one file)",
}


def _compare(name, fmt, ours, ref_t, ref_geo=None, ref_xyz=None, time_note="", counts=None):
    """One table row: ours (LogRecords) against reference times and geodetic or local positions (matched in order)."""
    n = min(len(ours), len(ref_t))
    if ref_geo is not None:
        origin = Origin(*map(float, ref_geo[0]))
        a = geodetic_to_enu(ours.values[:n, 0], ours.values[:n, 1], ours.values[:n, 2], origin)
        b = geodetic_to_enu(ref_geo[:n, 0], ref_geo[:n, 1], ref_geo[:n, 2], origin)
    else:
        a, b = ours.values[:n], ref_xyz[:n]
    horizontal = float(np.linalg.norm(a[:, :2] - b[:, :2], axis=1).max())
    vertical = float(np.abs(a[:, 2] - b[:, 2]).max())
    seconds = float(np.abs(ours.t[:n] - ref_t[:n]).max())
    counts = counts or f"{len(ours)} / {len(ref_t)}"
    return f"| `{name}` | {fmt} | {counts} | {horizontal:.4f} | {vertical:.4f} | {seconds:.4f} | {time_note} |"


def ulog(path):
    from pyulog import ULog

    d = ULog(str(path), ["vehicle_gps_position"]).get_dataset("vehicle_gps_position").data
    ok = d["fix_type"] >= 3
    geo = np.column_stack([d["lat"] * 1e-7, d["lon"] * 1e-7, d["alt_ellipsoid"] * 1e-3])[ok]
    return _compare(path.name, "ulog", read_log(path), d["time_utc_usec"][ok] * 1e-6, geo, time_note="time_utc_usec")


def dataflash(path):
    from pymavlink.DFReader import DFReader_binary

    log, rows = DFReader_binary(str(path)), []
    while (m := log.recv_match(type="GPS")) is not None:
        if m.Status >= 3 and getattr(m, "I", 0) == 0:
            rows.append((m._timestamp, m.Lat, m.Lng, m.Alt))
    r = np.array(rows)
    ours = read_log(path)
    geo = r[:, 1:].copy()
    if ours.altitude == "ellipsoid":  # compare positions in the same reference: undo tlsync's Alt - Und
        geo[:, 2] = ours.values[: len(geo), 2]
    return _compare(path.name, "dataflash", ours, r[:, 0], geo, time_note="pymavlink's GPS clock (week, ms, leap s)")


def tlog(path):
    from pymavlink import mavutil

    log, fixes, offsets, received = mavutil.mavlogfile(str(path)), [], [], []
    while (m := log.recv_match(type=["GPS_RAW_INT", "SYSTEM_TIME"])) is not None:
        if m.get_type() == "SYSTEM_TIME" and m.time_unix_usec > 0:
            offsets.append(m.time_unix_usec * 1e-6 - m.time_boot_ms * 1e-3)
        elif m.get_type() == "GPS_RAW_INT" and m.fix_type >= 3:
            fixes.append((m.time_usec * 1e-6, m.lat * 1e-7, m.lon * 1e-7, (m.alt_ellipsoid or m.alt) * 1e-3))
            received.append(m._timestamp)
    f = np.array(fixes)
    t = f[:, 0] + np.median(offsets)
    order = np.argsort(t, kind="stable")
    lag = np.array(received)[order] - t[order]
    note = (
        f"fix time from SYSTEM_TIME; receive stamps lag it by {np.median(lag):.3f} s median ({lag.min():.3f} to "
        f"{lag.max():.3f})"
    )
    return _compare(path.name, "tlog", read_log(path), t[order], f[order, 1:], time_note=note)


def fit(path):
    import fitdecode

    rows = []
    with fitdecode.FitReader(str(path)) as reader:
        for frame in reader:
            if (
                isinstance(frame, fitdecode.FitDataMessage)
                and frame.name == "record"
                and frame.get_value("position_lat", fallback=None) is not None
            ):
                alt = frame.get_value("enhanced_altitude", fallback=None)
                rows.append(
                    (
                        frame.get_value("timestamp").timestamp(),
                        frame.get_value("position_lat") * 180 / 2**31,
                        frame.get_value("position_long") * 180 / 2**31,
                        alt if alt is not None else frame.get_value("altitude"),
                    )
                )
    r = np.array(rows)
    order = np.argsort(r[:, 0], kind="stable")
    return _compare(path.name, "fit", read_log(path), r[order, 0], r[order, 1:], time_note="timestamp (whole s)")


def gopro(path):
    demo = os.environ.get("GPMF_DEMO")
    if not demo or not Path(demo).exists():
        return None
    import calendar

    def run(*args: str) -> str:
        return subprocess.run([demo, str(path), *args], capture_output=True, check=True).stdout.decode("latin-1")

    text, rates = run("-a", "-fGPS5"), run("-s")
    clock = re.search(r"GPS5 sampling rate = ([\d.]+)Hz \(time (-?[\d.]+) to", rates)
    rate, first = float(clock.group(1)), float(clock.group(2))
    samples = [
        [float(v) for v in re.findall(r"(-?[\d.]+)(?:deg|m)", line)[:3]]
        for line in re.findall(r"^\s+GPS5 (.*deg.*)$", text, flags=re.M)
    ]
    ref_t = first + np.arange(len(samples)) / rate  # gpmf-parser's sample clock: first + n / rate
    gpsu = re.findall(r'GPSU type .U. size 16 data: "(\d{12}\.\d{3})"', run("-a", "-g", "-fGPSU"))
    counts = [len(body.strip().splitlines()) for body in re.findall(r"SCALED DATA:\n((?:\s+GPS5 .*\n)*)", text)]
    starts = np.cumsum([0] + counts[:-1])
    anchors = []
    for g, n0 in zip(gpsu, starts):
        utc = calendar.timegm((2000 + int(g[:2]), int(g[2:4]), int(g[4:6]), int(g[6:8]), int(g[8:10]), 0)) + float(
            g[10:]
        )
        anchors.append(utc - ref_t[n0])
    ours = read_log(path)
    deviation = np.abs(np.array(anchors) - np.median(anchors))
    stale = deviation > 0.5
    jitter = f"GPSU within {deviation[~stale].max():.3f} s of one UTC offset" + (
        f", {stale.sum()} stale by {deviation[stale].max():.2f} s (left out)" if stale.any() else ""
    )
    shifted = type(ours)(**{**ours.__dict__, "t": ours.t - ours.video_time_zero})
    note = f"gpmf-parser's sample clock ({rate:.4f} Hz from {first:.4f} s) on the video timeline; {jitter}"
    return _compare(path.name, "gopro", shifted, ref_t, np.array(samples), time_note=note)


def rtklib(path):
    readpos = os.environ.get("RTKLIB_READPOS")
    if not readpos or not Path(readpos).exists():
        return None
    ref = np.loadtxt(subprocess.run([readpos, str(path)], capture_output=True, check=True).stdout.decode().splitlines())
    ref = ref[ref[:, 4] > 0]
    return _compare(path.name, "rtklib", read_log(path), ref[:, 0], ref[:, 1:4], time_note="RTKLIB readsolt + gpst2utc")


def dji_osd(path):
    import csv
    import datetime as dt

    rows = []
    with path.open(newline="", encoding="latin-1") as handle:
        for row in csv.DictReader(handle):
            if row["OSD.isGPSused"] == "True":
                stamp = row["CUSTOM.updateTime"]
                when = dt.datetime.strptime(stamp, "%Y/%m/%d %H:%M:%S.%f" if "." in stamp else "%Y/%m/%d %H:%M:%S")
                rows.append(
                    (
                        when.replace(tzinfo=dt.timezone.utc).timestamp(),
                        float(row["OSD.latitude"]),
                        float(row["OSD.longitude"]),
                        float(row["OSD.height [m]"]),
                    )
                )
    r = np.array(rows)
    return _compare(
        path.name,
        "dji",
        read_log(path),
        r[:, 0],
        r[:, 1:],
        time_note="CUSTOM.updateTime (the app's local clock, ms), by Python's csv",
    )


def airdata(path):
    """AirData's own GPX export of the same flight (the .gpx beside the CSV) against tlsync's reading of the CSV.

    Fixes are matched by their coordinates (the GPX copies the CSV's digits); times compared after
    removing one constant, which is named: AirData's GPX anchors time(millisecond) on the first row's
    whole second, tlsync on all rows' (tlsync_pipeline.ingest.clocks). The GPX leaves rows out; a
    comparison that interpolates it there sees the row's distance from the chord.
    """
    import csv
    import datetime as dt

    import gpxpy

    gpx_path = path.with_suffix(".gpx")
    if not gpx_path.exists():
        return None
    with gpx_path.open(encoding="utf-8") as handle:
        points = [p for track in gpxpy.parse(handle).tracks for segment in track.segments for p in segment.points]
    ref = np.array([[p.time.timestamp(), p.latitude, p.longitude, p.elevation] for p in points])
    ours = read_log(path)
    index = {}
    for i, (lat, lon) in enumerate(ours.values[:, :2]):
        index.setdefault((round(lat, 9), round(lon, 9)), i)
    pairs = [
        (index[key], k) for k, key in enumerate((round(a, 9), round(b, 9)) for a, b in ref[:, 1:3]) if key in index
    ]
    i, k = np.array(pairs).T
    shift = float(np.median(ours.t[i] - ref[k, 0]))
    matched = type(ours)(**{**ours.__dict__, "t": ours.t[i], "values": ours.values[i]})
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    clock = np.array([float(r["time(millisecond)"]) / 1000 for r in rows])
    whole = np.array(
        [dt.datetime.fromisoformat(r["datetime(utc)"]).replace(tzinfo=dt.timezone.utc).timestamp() for r in rows]
    )
    tlsync_c = float(np.median(ours.t - clock[ours.line - 2]))
    agree = lambda c: np.mean(np.floor(clock + c + 1e-6) == whole)  # noqa: E731
    left_out = np.setdiff1d(np.arange(len(ours)), i)
    left_out = left_out[(left_out > 0) & (left_out < len(ours) - 1)]
    origin = Origin(*map(float, ref[0, 1:]))
    a = geodetic_to_enu(ours.values[left_out, 0], ours.values[left_out, 1], ours.values[left_out, 2], origin)
    b = geodetic_to_enu(ref[:, 1], ref[:, 2], ref[:, 3], origin)
    chord = np.column_stack([np.interp(ours.t[left_out] - shift, ref[:, 0], b[:, j]) for j in range(3)])
    off = np.linalg.norm(a[:, :2] - chord[:, :2], axis=1)
    note = (
        f"after removing {shift:.3f} s: the GPX is time(millisecond) + the first row's whole second; datetime(utc) is "
        f"the floor of "
        f"tlsync's UTC in {agree(tlsync_c):.1%} of rows, of the GPX's in {agree(tlsync_c - shift):.1%}. The GPX "
        f"leaves out "
        f"{len(ours) - len(i)} rows; interpolated there it is {np.median(off):.3f} m (median) to {off.max():.3f} m "
        f"off them"
    )
    return _compare(
        path.name, "dji", matched, ref[k, 0] + shift, ref[k, 1:], time_note=note, counts=f"{len(ours)} / {len(ref)}"
    )


SRT_REFERENCE_JS = """
const [parser, file] = process.argv.slice(1);
const data = require(parser)(require('fs').readFileSync(file, 'utf8'), file);
data.setSmoothing(0);
const packets = data.metadata().packets.map(p => [p.TIMECODE || null, p.DATE, p.GPS.LATITUDE, p.GPS.LONGITUDE, p.ALTITUDE ?? p.BAROMETER ?? p.HB ?? null]);
process.stdout.write(JSON.stringify(packets));
"""


def srt(path):
    """DJI_SRT_Parser (smoothing off) against tlsync's SRT reader, fixes matched by subtitle time (else in order).

    The reference puts the local wall clock on UTC with the time zone at the first fix (tz-lookup);
    tlsync keeps it local without [target] utc_offset: the whole-hour difference is removed and named.
    Times compared: the wall clock where it has milliseconds; else the subtitle (video) times, the
    whole-second wall clock only anchoring them (the reference's whole seconds jitter by a second).
    """
    import json

    parser = os.environ.get("DJI_SRT_PARSER")
    if not parser or not Path(parser).exists():
        return None
    ref = json.loads(
        subprocess.run(
            ["node", "-e", SRT_REFERENCE_JS, str(Path(parser).resolve()), str(path)], capture_output=True, check=True
        ).stdout
    )
    ours = read_log(path)
    lines = path.read_text(encoding="utf-8-sig", errors="replace").replace("\r", "").split("\n")
    ours_code = [lines[n].split(" -->")[0].strip() if n < len(lines) and "-->" in lines[n] else None for n in ours.line]
    by_code = {code: i for i, code in enumerate(ours_code) if code}
    pairs = (
        [(by_code[r[0]], k) for k, r in enumerate(ref) if r[0] in by_code]
        if by_code
        else list(zip(range(len(ours)), range(len(ref))))
    )
    i, k = np.array(pairs).T
    r = np.array([[np.nan if v is None else float(v) for v in row[1:]] for row in ref])
    geo = r[k, 1:4]
    matched = type(ours)(**{**ours.__dict__, "t": ours.t[i], "values": ours.values[i]})
    if np.isnan(geo[:, 2]).all():
        geo[:, 2] = matched.values[:, 2]  # the reference reads no height here: compare positions only
    milliseconds = "subtitle (video) times agree" in ours.notes[1]
    ref_wall = r[k, 0] * 1e-3
    zone = (
        round(float(np.median(matched.t - ref_wall)) / 900) * 900
    )  # the reference's tz-lookup offset, whole quarter hours
    ref_wall = ref_wall + zone
    if milliseconds or not by_code:
        # the reference moves a date that repeats the next one back by half the step before it: not a reading difference
        repeated = np.r_[matched.t[1:] == matched.t[:-1], False]
        ref_t = np.where(repeated, matched.t, ref_wall)
        what = f"wall clock; the reference's time zone (UTC{zone / 3600:+g} h) removed" + (
            f", {repeated.sum()} repeated dates it moves left out" if repeated.any() else ""
        )
    else:
        codes = [ref[j][0] for j in k]
        ref_t = (
            np.array([int(c[:2]) * 3600 + int(c[3:5]) * 60 + int(c[6:8]) + int(c[9:12]) / 1000 for c in codes])
            + ours.video_time_zero
        )
        what = "subtitle times"
        if np.isfinite(ref_wall).all() and "wall clock" in ours.notes[1]:
            what += (
                f" anchored on the whole-second dates, which are within {np.abs(matched.t - ref_wall).max():.2f} "
                f"s of them (UTC{zone / 3600:+g} h removed)"
            )
    precision = next(n for n in ours.notes if n.startswith("precision"))
    kept = ingest(ours)[1].fixes_used
    kept_note = "all kept by the ingest" if kept == len(ours) else f"{len(ours) - kept} dropped by the ingest"
    note = f"{what}; {len(k)} matched, {kept_note}; {precision.split(',')[0].removeprefix('precision: ')}"
    return _compare(path.name, "srt", matched, ref_t, geo, time_note=note, counts=f"{len(ours)} / {len(ref)}")


def tum(path):
    ref = np.loadtxt(path, comments="#")
    return _compare(path.name, "tum", read_log(path), ref[:, 0], ref_xyz=ref[:, 1:4], time_note="the file's own clock")


def mcap(path):
    try:
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory
    except ImportError:
        return None
    rows = []
    with path.open("rb") as handle:
        for _, _, _, msg in make_reader(handle, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
            topics=["/odom"]
        ):
            p = msg.pose.pose.position
            rows.append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, p.x, p.y, p.z))
    r = np.array(sorted(rows, key=lambda row: row[0]))
    return _compare(
        path.name,
        "rosbag",
        read_log(path, topic="/odom"),
        r[:, 0],
        ref_xyz=r[:, 1:],
        time_note="header stamps (sim clock)",
    )


READERS = {
    "sample_log_small.ulg": ulog,
    "test.BIN": dataflash,
    "mav.tlog": tlog,
    "vtol.tlog": tlog,
    "activity-small-fenix2-run.fit": fit,
    "max-heromode.mp4": gopro,
    "freiburg1_xyz-groundtruth.txt": tum,
    "georeferenced.tum": tum,
    "nav2_turtlebot.mcap": mcap,
    "rover_1Hz_rtk.pos": rtklib,
    "dvm_drone_log.csv": dji_osd,
    "airdata_mini2.csv": airdata,
    **{name: srt for name in SOURCES if name.startswith("dji_srt_")},
}


def main() -> None:
    header = [
        "| file | format | fixes (tlsync / reference) | max horizontal (m) | max vertical (m) | max time (s) | time "
        "compared |",
        "|---|---|---|---|---|---|---|",
    ]
    rows, skipped = [], []
    for name, compare in READERS.items():
        path = REAL / name
        row = compare(path) if path.exists() else None
        (rows if row else skipped).append(row or name)
    if not rows:
        print(f"no real logs under {REAL}: nothing measured (see SOURCES in this script)")
        return
    table = "\n".join(header + rows)
    sources = "\n".join(f"- `{n}`: {s}" for n, s in SOURCES.items() if n not in skipped)
    print(table)
    if skipped:
        print("skipped (absent or reference reader missing):", ", ".join(skipped))
    if "--write" in sys.argv:
        write_block("ingest-real-files", f"{table}\n\nFiles (not in the repository):\n\n{sources}", DOC)


if __name__ == "__main__":
    main()
