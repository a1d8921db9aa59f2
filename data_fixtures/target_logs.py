"""Target logs of a known trajectory in the formats drones, robots and survey receivers write.

Each writer takes the POSIX UTC times ``t`` (N,) and WGS84 ``geo`` (N, 3)
lat/lon/height (above the ellipsoid) of the truth (``gps_logs.log_fixes``)
and writes the file as the device does, with its traps: GPS week and
leap seconds, boot clocks, 1e-7 degree integers and millimetres, feet,
whole-second UTC, rows before the fix, heights above MSL (the ellipsoid
height minus UNDULATION_M) where the format keeps them. Binary formats are written
with the format's own library where one can write it (pymavlink for tlogs,
rosbags in tests) and otherwise by following the format's specification
(ULog, DataFlash, GPMF KLV).
"""

from __future__ import annotations

import datetime as dt
import struct
from pathlib import Path

import numpy as np

from tlsync_pipeline.ingest.gps_time import GPS_EPOCH_POSIX, WEEK_S, leap_seconds

UNDULATION_M = 47.25  # geoid above the ellipsoid at the fixtures' site: MSL height = ellipsoid height - this


def gps_week_tow(t_utc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(GPS week, time of week s) of POSIX UTC times (adds the leap seconds in force)."""
    utc = np.asarray(t_utc, dtype=float)
    gpst = utc + leap_seconds(utc + 18.0) - GPS_EPOCH_POSIX
    week = np.floor(gpst / WEEK_S)
    return week.astype(int), gpst - week * WEEK_S


# --- PX4 ULog (format spec: https://docs.px4.io/main/en/dev_log/ulog_file_format.html) ---

_ULOG_FIELDS = (
    ("uint64_t", "timestamp", "Q"),
    ("uint64_t", "time_utc_usec", "Q"),
    ("int32_t", "lat", "i"),
    ("int32_t", "lon", "i"),
    ("int32_t", "alt", "i"),
    ("int32_t", "alt_ellipsoid", "i"),
    ("float", "eph", "f"),
    ("float", "epv", "f"),
    ("uint8_t", "fix_type", "B"),
    ("uint8_t", "satellites_used", "B"),
)


def _ulog_message(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def write_ulog(
    path, t: np.ndarray, geo: np.ndarray, boot_offset_s: float = 250.0, fix_type=None, eph=None, utc: bool = True
) -> Path:
    """A ULog with a vehicle_gps_position topic: boot-clock ``timestamp`` (UTC - boot_offset_s), UTC
    ``time_utc_usec`` (0 when ``utc`` is False), 1e-7 degree lat/lon, mm heights (MSL and ellipsoid)."""
    n = len(t)
    fix_type = np.full(n, 3) if fix_type is None else np.asarray(fix_type)
    eph = np.full(n, 0.8) if eph is None else np.asarray(eph)
    out = bytearray(b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 0))
    out += _ulog_message(b"B", bytes(16) + bytes(24))
    out += _ulog_message(
        b"F", ("vehicle_gps_position:" + "".join(f"{c} {name};" for c, name, _ in _ULOG_FIELDS)).encode()
    )
    out += _ulog_message(b"A", struct.pack("<BH", 0, 0) + b"vehicle_gps_position")
    layout = "<H" + "".join(code for _, _, code in _ULOG_FIELDS)
    for i in range(n):
        boot_us = int(round((t[i] - t[0] + boot_offset_s) * 1e6))
        lat, lon, h = geo[i]
        out += _ulog_message(
            b"D",
            struct.pack(
                layout,
                0,
                boot_us,
                int(round(t[i] * 1e6)) if utc else 0,
                int(round(lat * 1e7)),
                int(round(lon * 1e7)),
                int(round((h - UNDULATION_M) * 1e3)),
                int(round(h * 1e3)),
                float(eph[i]),
                1.2 * float(eph[i]),
                int(fix_type[i]),
                14,
            ),
        )
    Path(path).write_bytes(bytes(out))
    return Path(path)


# --- ArduPilot DataFlash (.bin): FMT table then messages, each after A3 95 <type> ---

_DF_FMT = (128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns")
_DF_GPS = (129, "GPS", "QBBIHBCLLe", "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt")
_DF_GPA = (130, "GPA", "QBCffIf", "TimeUS,I,VDop,HAcc,VAcc,SMS,Und")
_DF_CODES = {
    "Q": "Q",
    "B": "B",
    "I": "I",
    "H": "H",
    "C": "H",
    "L": "i",
    "e": "i",
    "f": "f",
    "n": "4s",
    "N": "16s",
    "Z": "64s",
    "i": "i",
}


def _df_struct(fmt: str) -> str:
    return "<" + "".join(_DF_CODES[c] for c in fmt)


def _df_fmt(kind: int, name: str, fmt: str, columns: str) -> bytes:
    length = 3 + struct.calcsize(_df_struct(fmt))
    return b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", kind, length, name.encode(), fmt.encode(), columns.encode())


def write_dataflash(
    path,
    t: np.ndarray,
    geo: np.ndarray,
    boot_offset_s: float = 40.0,
    status=None,
    week_zero_first: int = 0,
    gpa: bool = True,
) -> Path:
    """A DataFlash log: FMT table (whose text reads "Type,Length,Name,Format,Columns"), GPS with GPS week/ms
    and MSL height (cm), and (gpa) GPA with HAcc and ArduPilot's undulation (MSL minus ellipsoidal height, so
    -UNDULATION_M); the first week_zero_first fixes have week 0."""
    n = len(t)
    status = np.full(n, 6) if status is None else np.asarray(status)
    week, tow = gps_week_tow(t)
    out = bytearray()
    for kind, name, fmt, cols in (_DF_FMT, _DF_GPS, _DF_GPA):
        out += _df_fmt(kind, name, fmt, cols)
    for i in range(n):
        boot_us = int(round((t[i] - t[0] + boot_offset_s) * 1e6))
        lat, lon, h = geo[i]
        zero = i < week_zero_first
        out += (
            b"\xa3\x95"
            + bytes([_DF_GPS[0]])
            + struct.pack(
                _df_struct(_DF_GPS[2]),
                boot_us,
                0,
                int(status[i]),
                0 if zero else int(round(tow[i] * 1e3)),
                0 if zero else int(week[i]),
                15,
                70,
                int(round(lat * 1e7)),
                int(round(lon * 1e7)),
                int(round((h - UNDULATION_M) * 100)),
            )
        )
        if gpa:
            out += (
                b"\xa3\x95"
                + bytes([_DF_GPA[0]])
                + struct.pack(
                    _df_struct(_DF_GPA[2]), boot_us, 0, 90, 0.02, 0.03, int(round(tow[i] * 1e3)), -UNDULATION_M
                )
            )
    Path(path).write_bytes(bytes(out))
    return Path(path)


# --- MAVLink telemetry log (.tlog), written with pymavlink ---


def write_tlog(
    path,
    t: np.ndarray,
    geo: np.ndarray,
    boot_offset_s: float = 60.0,
    latency_s: float = 0.35,
    reboot_at: int | None = None,
    ground_station: bool = False,
) -> Path:
    """A tlog: each packet after its big-endian receive stamp (fix time + latency_s); GPS_RAW_INT on the boot
    clock with SYSTEM_TIME after each; the autopilot reboots before fix reboot_at (boot clock restarts at 20 s);
    ground_station: the ground station (system 255) also sends SYSTEM_TIME, with its own boot clock and a UTC 3 s off.
    """
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    out = bytearray()
    boot0 = t[0] - boot_offset_s
    for i in range(len(t)):
        if reboot_at is not None and i == reboot_at:
            boot0 = t[i] - 20.0
        boot = t[i] - boot0
        lat, lon, h = geo[i]
        receive = int(round((t[i] + latency_s) * 1e6))
        gps = mav.gps_raw_int_encode(
            int(round(boot * 1e6)),
            6,
            int(round(lat * 1e7)),
            int(round(lon * 1e7)),
            int(round((h - UNDULATION_M) * 1e3)),
            70,
            110,
            500,
            9000,
            15,
            int(round(h * 1e3)),
            20,
            30,
            100,
            0,
            0,
        )
        clock = mav.system_time_encode(int(round((t[i] + 0.01) * 1e6)), int(round((boot + 0.01) * 1e3)))
        for msg, extra in ((gps, 0), (clock, 5000)):
            out += struct.pack(">Q", receive + extra) + msg.pack(mav)
        if ground_station:
            other = gcs.system_time_encode(int(round((t[i] + 3.0) * 1e6)), int(round((t[i] - t[0] + 1.0) * 1e3)))
            out += struct.pack(">Q", receive + 7000) + other.pack(gcs)
    Path(path).write_bytes(bytes(out))
    return Path(path)


# --- RTKLIB .pos ---


def write_rtklib_pos(
    path,
    t: np.ndarray,
    geo: np.ndarray,
    layout: str = "calendar",
    system: str = "GPST",
    geodetic: bool = False,
    header: bool = True,
    q=None,
    sdn=None,
) -> Path:
    """An RTKLIB llh solution: calendar or GPS week/TOW times in GPST or UTC, ellipsoidal (or geodetic: MSL)
    heights, Q and sdn/sde/sdu columns; header False writes data lines only."""
    n = len(t)
    q = np.full(n, 1) if q is None else np.asarray(q)
    sdn = np.full(n, 0.01) if sdn is None else np.asarray(sdn)
    times = np.asarray(t, dtype=float) + (leap_seconds(np.asarray(t) + 18.0) if system == "GPST" else 0.0)
    lines = []
    if header:
        lines += [
            "% program   : RTKPOST ver.2.4.3 b34",
            f"% (lat/lon/height=WGS84/{'geodetic' if geodetic else 'ellipsoidal'},Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)",  # noqa: E501 (a real log's line)
            f"%  {system:<23s} latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  "
            f"sdeu(m)  sdun(m) age(s)  ratio",
        ]
    for i in range(n):
        lat, lon, h = geo[i]
        h = h - UNDULATION_M if geodetic else h
        if layout == "calendar":
            when = dt.datetime.fromtimestamp(round(times[i], 3), dt.timezone.utc).strftime("%Y/%m/%d %H:%M:%S.%f")[:-3]
        else:
            gpst = times[i] - GPS_EPOCH_POSIX
            week = int(gpst // WEEK_S)
            when = f"{week:4d} {gpst - week * WEEK_S:10.3f}"
        lines.append(
            f"{when}  {lat:14.9f} {lon:14.9f} {h:10.4f} {int(q[i]):3d} {12:3d} {sdn[i]:8.4f} {sdn[i]:8.4f} "
            f"{2 * sdn[i]:8.4f} {0:8.4f} {0:8.4f} {0:8.4f} {0:6.2f} {999.9:6.1f}"
        )
    Path(path).write_text("\n".join(lines) + "\n", encoding="ascii")
    return Path(path)


# --- KML ---


def _iso(t: float) -> str:
    return (
        dt.datetime.fromtimestamp(round(t, 3), dt.timezone.utc)
        .isoformat(timespec="milliseconds")
        .replace("+00:00", "Z")
    )


def write_kml_track(path, t: np.ndarray, geo: np.ndarray, altitude_mode: str = "absolute") -> Path:
    """A Google Earth gx:Track (when / gx:coord pairs, lon lat alt), heights above MSL."""
    whens = "\n".join(f"        <when>{_iso(ti)}</when>" for ti in t)
    coords = "\n".join(
        f"        <gx:coord>{lon:.7f} {lat:.7f} {h - UNDULATION_M:.2f}</gx:coord>" for lat, lon, h in geo
    )
    Path(path).write_text(
        f"""<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2" xmlns:gx="http://www.google.com/kml/ext/2.2">
  <Document>
    <name>track</name>
    <Placemark>
      <name>flight</name>
      <gx:Track>
        <altitudeMode>{altitude_mode}</altitudeMode>
{whens}
{coords}
      </gx:Track>
    </Placemark>
  </Document>
</kml>
""",
        encoding="utf-8",
    )
    return Path(path)


# --- TUM ---


def write_tum(path, t: np.ndarray, xyz: np.ndarray) -> Path:
    """``timestamp tx ty tz qx qy qz qw`` lines (identity orientation), with a comment header."""
    lines = ["# timestamp tx ty tz qx qy qz qw"] + [
        f"{ti:.6f} {x:.4f} {y:.4f} {z:.4f} 0 0 0 1" for ti, (x, y, z) in zip(t, xyz)
    ]
    Path(path).write_text("\n".join(lines) + "\n", encoding="ascii")
    return Path(path)


# --- DJI / AirData CSV ---


def write_airdata_csv(
    path,
    t: np.ndarray,
    geo: np.ndarray,
    no_fix_rows: int = 5,
    jitter_seed: int = 0,
    pause: tuple[int, float] | None = None,
) -> Path:
    """An AirData export: time(millisecond) from the flight start, datetime(utc) in whole seconds that lag
    the true second by 0 or 1 (jitter), heights in feet above MSL and above take-off, no_fix_rows rows with
    lat/lon 0 first; pause (row, seconds): the flight clock stops for that long (the UTC does not)."""
    rng = np.random.default_rng(jitter_seed)
    header = "time(millisecond),datetime(utc),latitude,longitude,height_above_takeoff(feet),altitude_above_seaLevel(feet),satellites,gpslevel,speed(mph)"  # noqa: E501 (a real log's line)
    rows = [header]
    clock0 = t[0] - 2.0
    for k in range(no_fix_rows):
        ms = int(round((k * 0.1) * 1e3))
        rows.append(
            f"{ms},{dt.datetime.fromtimestamp(int(clock0 + k * 0.1), dt.timezone.utc):%Y-%m-%d %H:%M:%S},0.0,0.0,0.0,0.0,0,0,0.0"  # noqa: E501 (a real log's line)
        )
    shift = 0.0
    for i in range(len(t)):
        if pause is not None and i == pause[0]:
            shift += pause[1]
        clock = t[i] - clock0 - shift
        whole = int(np.floor(t[i])) - int(rng.random() < 0.3)
        lat, lon, h = geo[i]
        msl_ft = (h - UNDULATION_M) / 0.3048
        rows.append(
            f"{int(round(clock * 1e3))},{dt.datetime.fromtimestamp(whole, dt.timezone.utc):%Y-%m-%d %H:%M:%S},{lat:.8f},{lon:.8f},"  # noqa: E501 (a real log's line)
            f"{(h - geo[0, 2]) / 0.3048:.1f},{msl_ft:.2f},17,5,12.3"
        )
    Path(path).write_text("\n".join(rows) + "\n", encoding="utf-8")
    return Path(path)


# --- DJI SRT subtitles ---

SRT_LAYOUTS = ("mavic_pro", "p4p", "m300", "air2", "mavic3")


def _timecode(seconds: float) -> str:
    ms = int(round(seconds * 1000))
    return f"{ms // 3_600_000:02d}:{ms // 60_000 % 60:02d}:{ms // 1000 % 60:02d},{ms % 1000:03d}"


def write_dji_srt(
    path,
    t: np.ndarray,
    geo: np.ndarray,
    layout: str,
    utc_offset_s: float = 7200.0,
    home=None,
    decimals: int | None = None,
) -> Path:
    """A DJI subtitle file: one block per instant t (UTC), subtitle times from 0 at t[0], the wall clock in local
    time (UTC + utc_offset_s) as each generation writes it (layout, one of SRT_LAYOUTS):

    - "mavic_pro": HOME(lon,lat) and a whole-second date, GPS(lon,lat,satellites) BAROMETER (4 decimals);
    - "p4p": one line, GPS (lon, lat, satellites), D (to home, m), H (m), H.S (m/s); no date (4 decimals);
    - "m300": whole-second date, GPS(lat,lon,0.0M) BAROMETER (4 decimals);
    - "air2": per frame, date with ms and us, [latitude: ..] [longitude: ..] [altitude: ..] (6 decimals);
    - "mavic3": per frame, date with ms, [latitude: ..] [longitude: ..] [rel_alt: .. abs_alt: ..] (5 decimals).

    Heights: BAROMETER, H and rel_alt above geo[0]; altitude and abs_alt MSL (h - UNDULATION_M).
    home (lat, lon): the HOME point, geo[0] by default.
    """
    home = geo[0, :2] if home is None else np.asarray(home, dtype=float)
    places = decimals if decimals is not None else {"air2": 6, "mavic3": 5}.get(layout, 4)
    f = lambda v: f"{v:.{places}f}"  # noqa: E731
    media = np.asarray(t) - t[0]
    step = float(np.median(np.diff(media))) if len(media) > 1 else 1.0
    blocks = []
    for k, (ti, (lat, lon, h)) in enumerate(zip(t, geo)):
        local = dt.datetime.fromtimestamp(ti + utc_offset_s, dt.timezone.utc)
        rel, msl = h - geo[0, 2], h - UNDULATION_M
        north = np.radians(lat - home[0]) * 6_371_000.0
        east = np.radians(lon - home[1]) * 6_371_000.0 * np.cos(np.radians(lat))
        speed = (
            0.0
            if k == 0
            else float(
                np.hypot(*(np.radians(geo[k, :2] - geo[k - 1, :2]) * 6_371_000.0 * [1.0, np.cos(np.radians(lat))]))
                / (t[k] - t[k - 1])
            )
        )
        if layout == "mavic_pro":
            body = (
                f"HOME({f(home[1])},{f(home[0])}) {local:%Y.%m.%d %H:%M:%S}\nGPS({f(lon)},{f(lat)},17) "
                f"BAROMETER:{rel:.1f}\n"
                "ISO:100 Shutter:60 EV: Fnum:2.2"
            )
        elif layout == "p4p":
            body = (
                f"F/3.2, SS 160, ISO 100, EV 0, GPS ({f(lon)}, {f(lat)}, 18), D {np.hypot(north, east):.2f}m, H "
                f"{rel:.2f}m, "
                f"H.S {speed:.2f}m/s, V.S 0.00m/s"
            )
        elif layout == "m300":
            body = f"{local:%Y.%m.%d %H:%M:%S}\nGPS({f(lat)},{f(lon)},0.0M) BAROMETER:{rel:.1f}M"
        elif layout == "air2":
            body = (
                f'<font size="36">SrtCnt : {k + 1}, DiffTime : {int(round(step * 1000))}ms\n'
                f"{local:%Y-%m-%d %H:%M:%S},{local.microsecond // 1000:03d},{local.microsecond % 1000:03d}\n"
                f"[iso : 100] [shutter : 1/500.0] [fnum : 280] [ev : 0] [ct : 5500] [color_md : default] [focal_len : "
                f"240] "
                f"[latitude: {f(lat)}] [longitude: {f(lon)}] [altitude: {msl:.6f}] </font>"
            )
        elif layout == "mavic3":
            body = (
                f'<font size="28">FrameCnt: {k + 1}, DiffTime: {int(round(step * 1000))}ms\n'
                f"{local:%Y-%m-%d %H:%M:%S}.{local.microsecond // 1000:03d}\n"
                f"[iso: 220] [shutter: 1/8000.0] [fnum: 3.2] [ev: 0] [ct: 5115] [color_md : default] [focal_len: "
                f"24.00] "
                f"[latitude: {f(lat)}] [longitude: {f(lon)}] [rel_alt: {rel:.3f} abs_alt: {msl:.3f}] </font>"
            )
        else:
            raise ValueError(f"layout {layout!r}: expected one of {SRT_LAYOUTS}")
        blocks.append(f"{k + 1}\n{_timecode(media[k])} --> {_timecode(media[k] + step)}\n{body}\n")
    Path(path).write_text("\n".join(blocks), encoding="utf-8")
    return Path(path)


# --- GoPro GPMF payloads (KLV) ---


def gpmf_klv(key: bytes, kind: str, size: int, values: bytes, repeat: int) -> bytes:
    """One KLV item: FourCC, type character ("" = nested), structure size, repeat count, data padded to 4 bytes."""
    data = key + bytes([ord(kind) if kind else 0, size]) + struct.pack(">H", repeat) + values
    return data + bytes((-len(values)) % 4)


def gpmf_payload(
    lat_lon_alt: np.ndarray,
    gpsu_utc: float | None,
    fix: int = 3,
    dop: float = 1.5,
    msl: bool = False,
    stmp_us: int | None = None,
    shutter_stmp_us: int | None = None,
) -> bytes:
    """One GPMF payload (DEVC > STRM) with GPSU, GPSF, GPSP, SCAL and a GPS5 block of the given samples.

    stmp_us: the GPS stream's STMP (camera microseconds at its first sample, HERO8 onwards);
    shutter_stmp_us: a SHUT stream (the video's exposure times) with that STMP, before the GPS stream.
    """
    scal = (10_000_000, 10_000_000, 1000, 1000, 100)
    samples = b"".join(
        struct.pack(">5i", int(round(a * scal[0])), int(round(b * scal[1])), int(round(c * scal[2])), 0, 0)
        for a, b, c in lat_lon_alt
    )
    stream = b"" if stmp_us is None else gpmf_klv(b"STMP", "J", 8, struct.pack(">Q", stmp_us), 1)
    if gpsu_utc is not None:
        whole = dt.datetime.fromtimestamp(np.floor(gpsu_utc), dt.timezone.utc)
        text = whole.strftime("%y%m%d%H%M%S") + f"{gpsu_utc - np.floor(gpsu_utc):.3f}"[1:]
        stream += gpmf_klv(b"GPSU", "U", 16, text.encode().ljust(16, b"\0"), 1)
    stream += gpmf_klv(b"GPSF", "L", 4, struct.pack(">I", fix), 1)
    stream += gpmf_klv(b"GPSP", "S", 2, struct.pack(">H", int(round(dop * 100))), 1)
    if msl:
        stream += gpmf_klv(b"GPSA", "F", 4, b"MSLV", 1)
    stream += gpmf_klv(b"SCAL", "l", 4, struct.pack(">5i", *scal), 5)
    stream += gpmf_klv(b"GPS5", "l", 20, samples, len(lat_lon_alt))
    strm = gpmf_klv(b"STRM", "", 1, stream, len(stream))
    if shutter_stmp_us is not None:
        shut = gpmf_klv(b"STMP", "J", 8, struct.pack(">Q", shutter_stmp_us), 1) + gpmf_klv(
            b"SHUT", "f", 4, struct.pack(">f", 0.001), 1
        )
        strm = gpmf_klv(b"STRM", "", 1, shut, len(shut)) + strm
    return gpmf_klv(b"DEVC", "", 1, strm, len(strm))


# --- Garmin FIT (format spec: the FIT SDK's "FIT Protocol"; fitdecode has no writer) ---

FIT_EPOCH_POSIX = 631065600  # 1989-12-31 00:00:00 UTC
_FIT_CRC = (
    0x0000,
    0xCC01,
    0xD801,
    0x1400,
    0xF001,
    0x3C00,
    0x2800,
    0xE401,
    0xA001,
    0x6C00,
    0x7800,
    0xB401,
    0x5000,
    0x9C01,
    0x8801,
    0x4400,
)


def _fit_crc(data: bytes) -> int:
    crc = 0
    for byte in data:
        for nibble in (byte & 0xF, byte >> 4):
            tmp = _FIT_CRC[crc & 0xF]
            crc = ((crc >> 4) & 0x0FFF) ^ tmp ^ _FIT_CRC[nibble]
    return crc


def _fit_message(local: int, global_number: int, fields: list[tuple[int, str, int]], rows: list[tuple]) -> bytes:
    """A definition (fields: number, struct code, FIT base type) then one data message per row."""
    out = bytes([0x40 | local, 0, 0]) + struct.pack("<HB", global_number, len(fields))
    out += b"".join(bytes([number, struct.calcsize(code), base]) for number, code, base in fields)
    layout = "<" + "".join(code for _, code, _ in fields)
    return out + b"".join(bytes([local]) + struct.pack(layout, *row) for row in rows)


def write_fit_device_clock(path, t: np.ndarray, geo: np.ndarray, power_on_utc: float, correlation: bool = True) -> Path:
    """A camera-style FIT: ``record`` timestamps in whole seconds since power-on (below 0x10000000, not
    UTC), semicircle positions, enhanced_altitude (MSL: ellipsoid - UNDULATION_M), and one
    ``timestamp_correlation`` tying device time to UTC (with fractional parts). t must be
    power_on_utc + whole seconds; correlation False leaves the timestamp_correlation out."""
    device = np.round(np.asarray(t) - power_on_utc).astype(int)
    utc_c = power_on_utc + 10.0
    whole = int(np.floor(utc_c))
    body = _fit_message(0, 0, [(0, "B", 0x00), (4, "I", 0x86)], [(4, whole - FIT_EPOCH_POSIX)])
    if correlation:
        body += _fit_message(
            1,
            162,
            [(253, "I", 0x86), (0, "H", 0x84), (1, "I", 0x86), (2, "H", 0x84)],
            [(whole - FIT_EPOCH_POSIX, int(round((utc_c - whole) * 32768)), 10, 0)],
        )
    semicircle = 2**31 / 180.0
    rows = [
        (
            int(d),
            int(round(lat * semicircle)),
            int(round(lon * semicircle)),
            int(round(((h - UNDULATION_M) + 500.0) * 5)),
        )
        for d, (lat, lon, h) in zip(device, geo)
    ]
    body += _fit_message(2, 20, [(253, "I", 0x86), (0, "i", 0x85), (1, "i", 0x85), (78, "I", 0x86)], rows)
    header = struct.pack("<BBHI4s", 14, 0x20, 2132, len(body), b".FIT")
    header += struct.pack("<H", _fit_crc(header))
    data = header + body
    Path(path).write_bytes(data + struct.pack("<H", _fit_crc(data)))
    return Path(path)


def write_fit_virb(
    path, t: np.ndarray, geo: np.ndarray, power_on_utc: float, correlation: str | None = "ms", jitter_seed: int = 0
) -> Path:
    """A Garmin VIRB-style FIT: ``gps_metadata`` fixes (10 Hz) timed by ``timestamp`` (whole seconds since
    power-on) + ``timestamp_ms``, each with a whole-second ``utc_timestamp`` (the UTC second it fell in, 30 % of
    them a second early), semicircles, enhanced_altitude (MSL: ellipsoid - UNDULATION_M); and a
    ``timestamp_correlation`` written 2.5 s after power-on with its sub-seconds in ``timestamp_ms`` /
    ``system_timestamp_ms`` (correlation "ms", as the VIRB), in ``fractional_timestamp`` /
    ``fractional_system_timestamp`` ("fractional"), or none (None)."""
    rng = np.random.default_rng(jitter_seed)
    device = np.asarray(t) - power_on_utc
    body = _fit_message(0, 0, [(0, "B", 0x00), (4, "I", 0x86)], [(4, int(power_on_utc) - FIT_EPOCH_POSIX)])
    device_c, utc_c = 2.5, power_on_utc + 2.5
    if correlation == "ms":
        body += _fit_message(
            1,
            162,
            [(253, "I", 0x86), (4, "H", 0x84), (1, "I", 0x86), (5, "H", 0x84)],
            [
                (
                    int(utc_c) - FIT_EPOCH_POSIX,
                    int(round((utc_c % 1) * 1000)),
                    int(device_c),
                    int(round((device_c % 1) * 1000)),
                )
            ],
        )
    elif correlation == "fractional":
        body += _fit_message(
            1,
            162,
            [(253, "I", 0x86), (0, "H", 0x84), (1, "I", 0x86), (2, "H", 0x84)],
            [
                (
                    int(utc_c) - FIT_EPOCH_POSIX,
                    int(round((utc_c % 1) * 32768)),
                    int(device_c),
                    int(round((device_c % 1) * 32768)),
                )
            ],
        )
    semicircle = 2**31 / 180.0
    rows = []
    for d, ti, (lat, lon, h) in zip(device, t, geo):
        whole = int(np.floor(d))
        ms = int(round((d - whole) * 1000))
        if ms == 1000:
            whole, ms = whole + 1, 0
        utc_second = int(np.floor(ti)) - int(rng.random() < 0.3)
        rows.append(
            (
                whole,
                ms,
                int(round(lat * semicircle)),
                int(round(lon * semicircle)),
                int(round(((h - UNDULATION_M) + 500.0) * 5)),
                utc_second - FIT_EPOCH_POSIX,
            )
        )
    body += _fit_message(
        2, 160, [(253, "I", 0x86), (0, "H", 0x84), (1, "i", 0x85), (2, "i", 0x85), (3, "I", 0x86), (6, "I", 0x86)], rows
    )
    header = struct.pack("<BBHI4s", 14, 0x20, 2132, len(body), b".FIT")
    header += struct.pack("<H", _fit_crc(header))
    data = header + body
    Path(path).write_bytes(data + struct.pack("<H", _fit_crc(data)))
    return Path(path)


def gpmf_gps9_payload(t_utc: np.ndarray, lat_lon_alt: np.ndarray, fix: np.ndarray, dop: float = 1.2) -> bytes:
    """One GPMF payload with a GPS9 block (HERO11 onwards): each sample carries days since 2000 and
    seconds since midnight (UTC, ms), DOP x 100 and its fix; TYPE ``lllllllSS``, 9 SCAL values."""
    scal = (10_000_000, 10_000_000, 1000, 1000, 100, 1, 1000, 100, 1)
    samples = b""
    for ti, (a, b, c), f in zip(t_utc, lat_lon_alt, fix):
        days, seconds = divmod(ti - 946684800.0, 86400.0)
        samples += struct.pack(
            ">7i2H",
            int(round(a * scal[0])),
            int(round(b * scal[1])),
            int(round(c * scal[2])),
            0,
            0,
            int(days),
            int(round(seconds * 1000)),
            int(round(dop * 100)),
            int(f),
        )
    stream = gpmf_klv(b"TYPE", "c", 1, b"lllllllSS", 9)
    stream += gpmf_klv(b"SCAL", "l", 4, struct.pack(">9i", *scal), 9)
    stream += gpmf_klv(b"GPS9", "?", 32, samples, len(t_utc))
    strm = gpmf_klv(b"STRM", "", 1, stream, len(stream))
    return gpmf_klv(b"DEVC", "", 1, strm, len(strm))
