"""GoPro MP4 files: the GPS fixes in the GPMF metadata track, demuxed with PyAV.

The metadata track is the data stream whose packets start with a ``DEVC``
item (handler "GoPro MET"); each packet (about one second) is parsed by
tlsync_pipeline.ingest.gpmf. Sample times on the video's timeline spread
each packet's samples evenly over its presentation interval [pts, pts +
duration). UTC: GPS9 samples carry their own (days since 2000 + seconds
since midnight); for GPS5 the payload's ``GPSU`` is the UTC of its first
sample, and the video timeline is put on UTC by the median of GPSU - packet
start over the file (one offset, so GPSU's jitter does not move samples, and a
stale GPSU, as the first payload often has, is outvoted; the report counts
those off by more than 0.5 s).
Heights are above MSL when the stream says ``GPSA`` = ``MSLV``, else above
the WGS84 ellipsoid (GPS5 on HERO5-HERO7). Payloads with ``GPSF`` < 2 (no
fix) and GPS9 samples with fix < 2 are dropped; DOP (``GPSP`` / 100) is kept.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.gpmf import GPMFError, gps_blocks
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.records import ELLIPSOID, GEODETIC, MSL, LogRecords, check_geodetic, make_records

UNIT = "GPS sample"
NO_FIX = "no fix (GPSF or GPS9 fix < 2)"
DAYS_2000_POSIX = 946684800.0
STALE_GPSU_S = 0.5


def _sniff(head: bytes) -> bool:
    return len(head) >= 12 and head[4:8] == b"ftyp"


def read_gopro(path: str | Path) -> LogRecords:
    """Read the GPS samples of a GoPro MP4; see the module notes."""
    path = Path(path)
    import av

    packets = []
    try:
        with av.open(str(path)) as container:
            for stream in container.streams:
                if stream.type != "data":
                    continue
                first = next(iter(container.demux(stream)), None)
                container.seek(0)
                if first is None or not bytes(first).startswith(b"DEVC"):
                    continue
                for packet in container.demux(stream):
                    if packet.pts is None or packet.size == 0:
                        continue
                    tb = float(packet.time_base)
                    packets.append((packet.pts * tb, (packet.duration or 0) * tb, bytes(packet)))
                break
    except av.error.FFmpegError as exc:
        raise InputError(f"{path}: cannot read as MP4: {exc}") from None
    if not packets:
        raise InputError(f"{path}: no GoPro GPMF metadata track (a data stream starting with DEVC); is this a GoPro HERO5-or-later video?")
    return gopro_records(path, packets)


def gopro_records(path: Path, packets: list[tuple[float, float, bytes]]) -> LogRecords:
    """LogRecords from (start s, duration s, GPMF payload) packets in video time order."""
    rows, numbers, dops = [], [], []
    dropped: dict[str, list[int]] = {}
    anchors = []  # GPSU - video time of the packet's first sample
    msl_seen, nine_seen, number = set(), False, 0
    for k, (start, duration, payload) in enumerate(packets):
        try:
            blocks = gps_blocks(payload)
        except GPMFError as exc:
            raise InputError(f"{path}: GPMF packet {k + 1} (at {start:.3f} s): {exc}") from None
        for block in blocks:
            n = len(block.samples)
            video_t = start + duration * np.arange(n) / max(n, 1)
            ok = np.full(n, block.fix is None or block.fix >= 2)
            if block.nine:
                ok &= block.samples[:, 8] >= 2
                t = DAYS_2000_POSIX + block.samples[:, 5] * 86400.0 + block.samples[:, 6]
                nine_seen = True
            else:
                t = video_t
                if block.utc is not None and ok.any():
                    anchors.append(block.utc - video_t[0])
            numbers_here = number + 1 + np.arange(n)
            number += n
            if (~ok).any():
                dropped.setdefault(NO_FIX, []).extend(numbers_here[~ok].tolist())
            msl_seen.add(block.msl)
            for i in np.flatnonzero(ok):
                lat, lon, alt = block.samples[i, :3]
                check_geodetic(path, lat, lon, alt, int(numbers_here[i]), UNIT)
                rows.append([t[i], lat, lon, alt])
                numbers.append(int(numbers_here[i]))
                dops.append(block.samples[i, 7] if block.nine else (block.dop if block.dop is not None else np.nan))
    if number == 0:
        raise InputError(f"{path}: the GPMF track has no GPS5/GPS9 stream (a camera without GPS, or with GPS switched off)")
    warnings = []
    utc = nine_seen or bool(anchors)
    if rows and not nine_seen:
        data = np.asarray(rows)
        if anchors:
            offset = float(np.median(anchors))
            data[:, 0] += offset
            stale = int(np.sum(np.abs(np.asarray(anchors) - offset) > STALE_GPSU_S))
            if stale:
                warnings.append(f"{stale} payload(s) with a GPSU more than {STALE_GPSU_S:g} s off the others (stale, as GoPros write before the time settles): not used for UTC")
        else:
            warnings.append("no GPSU in the GPS stream: times are the video's presentation times; offsets work, UTC does not")
        rows = data.tolist()
    if len(msl_seen) > 1:
        warnings.append("the GPS stream changes its altitude system (GPSA) mid-file: heights mix MSL and ellipsoid")
    altitude = MSL if True in msl_seen and False not in msl_seen else ELLIPSOID
    return make_records(
        path, "gopro", GEODETIC, rows, numbers, unit=UNIT, utc=utc, dropped=dropped, warnings=warnings, altitude=altitude,
        quality={"dop": dops}, clock=None if utc else "video presentation time (s)",
    )


READER = Reader("gopro", "GoPro MP4 with a GPMF track (bytes 4-7 'ftyp')", read_gopro, _sniff)
