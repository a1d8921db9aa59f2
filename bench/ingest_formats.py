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
header says, path in $RTKLIB_READPOS), GoPro's gpmf-parser C demo (GPMF; build it from the
gpmf-parser sources with printf precision raised to %.8f and give its path
in $GPMF_DEMO), numpy.loadtxt (TUM), Python's csv module (DJI: a CSV has
no other reader), the mcap library with mcap-ros2-support
(MCAP). The GoPro time is compared twice: the sample times on the video
timeline, and the UTC anchoring (each payload's GPSU against tlsync's one
median offset: GPSU's own jitter).
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
from tlsync_pipeline.ingest import read_log  # noqa: E402

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
    "dvm_drone_log.csv": "egemose/DroneVideoMeasure tests/test_data/test_drone_log.csv (MIT; a DJI Phantom 4 Pro flight, OSD layout)",
}


def _compare(name, fmt, ours, ref_t, ref_geo=None, ref_xyz=None, time_note=""):
    """One table row: ours (LogRecords) against reference times and geodetic or local positions."""
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
    counts = f"{len(ours)} / {len(ref_t)}"
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
    note = f"fix time from SYSTEM_TIME; receive stamps lag it by {np.median(lag):.3f} s median ({lag.min():.3f} to {lag.max():.3f})"
    return _compare(path.name, "tlog", read_log(path), t[order], f[order, 1:], time_note=note)


def fit(path):
    import fitdecode

    rows = []
    with fitdecode.FitReader(str(path)) as reader:
        for frame in reader:
            if isinstance(frame, fitdecode.FitDataMessage) and frame.name == "record" and frame.get_value("position_lat", fallback=None) is not None:
                alt = frame.get_value("enhanced_altitude", fallback=None)
                rows.append((frame.get_value("timestamp").timestamp(), frame.get_value("position_lat") * 180 / 2**31,
                             frame.get_value("position_long") * 180 / 2**31, alt if alt is not None else frame.get_value("altitude")))
    r = np.array(rows)
    order = np.argsort(r[:, 0], kind="stable")
    return _compare(path.name, "fit", read_log(path), r[order, 0], r[order, 1:], time_note="timestamp (whole s)")


def gopro(path):
    demo = os.environ.get("GPMF_DEMO")
    if not demo or not Path(demo).exists():
        return None
    import calendar

    run = lambda *args: subprocess.run([demo, str(path), *args], capture_output=True, check=True).stdout.decode("latin-1")  # noqa: E731
    text, rates = run("-a", "-fGPS5"), run("-s")
    clock = re.search(r"GPS5 sampling rate = ([\d.]+)Hz \(time (-?[\d.]+) to", rates)
    rate, first = float(clock.group(1)), float(clock.group(2))
    samples = [[float(v) for v in re.findall(r"(-?[\d.]+)(?:deg|m)", line)[:3]] for line in re.findall(r"^\s+GPS5 (.*deg.*)$", text, flags=re.M)]
    ref_t = first + np.arange(len(samples)) / rate  # gpmf-parser's sample clock: first + n / rate
    gpsu = re.findall(r'GPSU type .U. size 16 data: "(\d{12}\.\d{3})"', run("-a", "-g", "-fGPSU"))
    counts = [len(body.strip().splitlines()) for body in re.findall(r"SCALED DATA:\n((?:\s+GPS5 .*\n)*)", text)]
    starts = np.cumsum([0] + counts[:-1])
    anchors = []
    for g, n0 in zip(gpsu, starts):
        utc = calendar.timegm((2000 + int(g[:2]), int(g[2:4]), int(g[4:6]), int(g[6:8]), int(g[8:10]), 0)) + float(g[10:])
        anchors.append(utc - ref_t[n0])
    ours = read_log(path)
    offset = float(np.median(anchors))
    deviation = np.abs(np.array(anchors) - offset)
    stale = deviation > 0.5
    jitter = f"GPSU within {deviation[~stale].max():.3f} s of one UTC offset" + (f", {stale.sum()} stale by {deviation[stale].max():.2f} s (left out)" if stale.any() else "")
    shifted = type(ours)(**{**ours.__dict__, "t": ours.t - ours.video_time_zero})
    note = f"gpmf-parser's sample clock ({rate:.4f} Hz from {first:.4f} s) on the video timeline; tlsync's UTC is {ours.video_time_zero - offset:+.4f} s from the reference's median; {jitter}"
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
                rows.append((when.replace(tzinfo=dt.timezone.utc).timestamp(), float(row["OSD.latitude"]), float(row["OSD.longitude"]), float(row["OSD.height [m]"])))
    r = np.array(rows)
    return _compare(path.name, "dji", read_log(path), r[:, 0], r[:, 1:], time_note="CUSTOM.updateTime (the app's local clock, ms), by Python's csv")


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
        for _, _, _, msg in make_reader(handle, decoder_factories=[DecoderFactory()]).iter_decoded_messages(topics=["/odom"]):
            p = msg.pose.pose.position
            rows.append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, p.x, p.y, p.z))
    r = np.array(sorted(rows, key=lambda row: row[0]))
    return _compare(path.name, "rosbag", read_log(path, topic="/odom"), r[:, 0], ref_xyz=r[:, 1:], time_note="header stamps (sim clock)")


READERS = {
    "sample_log_small.ulg": ulog, "test.BIN": dataflash, "mav.tlog": tlog, "vtol.tlog": tlog,
    "activity-small-fenix2-run.fit": fit, "max-heromode.mp4": gopro, "freiburg1_xyz-groundtruth.txt": tum,
    "georeferenced.tum": tum, "nav2_turtlebot.mcap": mcap, "rover_1Hz_rtk.pos": rtklib,
    "dvm_drone_log.csv": dji_osd,
}


def main() -> None:
    header = ["| file | format | fixes (tlsync / reference) | max horizontal (m) | max vertical (m) | max time (s) | time compared |", "|---|---|---|---|---|---|---|"]
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
