"""Reading a 1-hour 10 Hz NMEA log (36,000 fixes, GGA + RMC, 72,000+ lines), generated in the run.

Also, for reference, the same hour as GPX (gpxpy), as CSV (ISO times), as an RTKLIB solution, a KML gx:Track
and a per-frame DJI SRT (Air 2 layout): each read (``read_log``), in CPU seconds, per fix and for a day at 10 Hz.

Prints the time to read the log (tlsync's reader), to ingest it (read + ENU +
spikes + gaps + resampling), and, for comparison, to parse every line with
pynmea2 and read its fields (the straightforward way). Times are also given
as a ratio to a fixed numpy workload (sorting 1e7 floats) measured in the
same run. Best of 3. Goal: the whole ingest under 2 s.
Run: python bench/ingest_speed.py
"""

from __future__ import annotations

import datetime as dt
import tempfile
import time
from pathlib import Path

import numpy as np
import pynmea2

from data_fixtures.gps_logs import (
    log_fixes,
    walk_trajectory,
    write_csv_log,
    write_gpx_log,
    write_nmea_log,
)
from data_fixtures.target_logs import write_dji_srt, write_kml_track, write_rtklib_pos
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest import IngestParams, ingest, read_log
from tlsync_pipeline.ingest.nmea import read_nmea


def _best(fn, repeats: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def _cpu(fn) -> tuple[float, object]:
    """(CPU seconds of the process, result) of one call: steadier than wall time on a loaded machine."""
    start = time.process_time()
    out = fn()
    return time.process_time() - start, out


def _baseline() -> float:
    data = np.random.default_rng(0).random(10_000_000)
    return _best(lambda: np.sort(data))[0]


def _pynmea2_only(path: Path) -> int:
    fixes = 0
    for line in path.read_text(encoding="ascii").splitlines():
        try:
            msg = pynmea2.parse(line, check=True)
        except pynmea2.ParseError:
            continue
        if msg.sentence_type == "GGA":
            _ = (msg.latitude, msg.longitude, msg.altitude, msg.geo_sep, msg.gps_qual, msg.timestamp)
            fixes += 1
        elif msg.sentence_type == "RMC":
            _ = msg.datestamp
    return fixes


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        hour = walk_trajectory(seconds=3600.0, rate=10.0, gap=(1800.0, 30.0))
        origin, start = Origin(47.3769, 8.5417, 450.0), dt.datetime(2026, 3, 1, 23, 30, tzinfo=dt.timezone.utc)
        path = write_nmea_log(Path(folder) / "hour.nmea", hour, origin, start, corrupt=range(0, 36_000, 997))
        gpx = write_gpx_log(Path(folder) / "hour.gpx", hour, origin, start)
        csv = write_csv_log(Path(folder) / "hour.csv", hour, origin, start)
        lines = path.read_bytes().count(b"\n")
        baseline = _baseline()
        read_s, records = _best(lambda: read_nmea(path))
        ingest_s, (trajectory, report) = _best(lambda: ingest(read_nmea(path), IngestParams()))
        pynmea2_s, fixes = _best(lambda: _pynmea2_only(path), repeats=1)
        gpx_s, _ = _best(lambda: ingest(read_log(gpx)), repeats=1)
        csv_s, _ = _best(lambda: ingest(read_log(csv)), repeats=1)
        t, geo = log_fixes(hour, origin, start)
        others = {
            "NMEA": path,
            "GPX": gpx,
            "RTKLIB .pos": write_rtklib_pos(Path(folder) / "hour.pos", t, geo),
            "KML gx:Track": write_kml_track(Path(folder) / "hour.kml", t, geo),
            "DJI SRT (per frame)": write_dji_srt(Path(folder) / "hour.srt", t, geo, "air2"),
        }
        reads = {name: _cpu(lambda p=log: read_log(p)) for name, log in others.items()}
    print(
        f"log: {lines:,} lines, {len(records):,} fixes read, {report.samples:,} samples, "
        f"{sum(d['count'] for d in report.dropped.values())} lines dropped, {len(report.gaps)} gap"
    )
    print(f"baseline (sort 1e7 floats): {baseline * 1000:.0f} ms")
    print("| step | s | x baseline |")
    print("|---|---:|---:|")
    for name, seconds in (
        ("read_nmea (tlsync)", read_s),
        ("read + ingest (tlsync)", ingest_s),
        ("pynmea2.parse every line + fields", pynmea2_s),
        ("same hour, GPX: read (gpxpy) + ingest", gpx_s),
        ("same hour, CSV (ISO times): read + ingest", csv_s),
    ):
        print(f"| {name} | {seconds:.3f} | {seconds / baseline:.1f} |")
    print("| format (the same hour) | fixes | read, CPU s | us a fix | a day at 10 Hz, CPU s |")
    print("|---|---:|---:|---:|---:|")
    for name, (seconds, read) in reads.items():
        per_fix = seconds / len(read)
        print(f"| {name} | {len(read):,} | {seconds:.3f} | {per_fix * 1e6:.1f} | {per_fix * 864_000:.1f} |")
    print(f"goal: read + ingest < 2 s: {'met' if ingest_s < 2 else 'NOT met'} ({ingest_s:.2f} s)")


if __name__ == "__main__":
    main()
