"""GoPro MP4 files: the GPS fixes in the GPMF metadata track, demuxed with PyAV; raw GPMF streams (``.raw``).

The metadata track is the data stream whose packets start with a ``DEVC``
item (handler "GoPro MET"); each packet (a payload of about one second) is
parsed by tlsync_pipeline.ingest.gpmf.

Sample times on the video's timeline (media time, s) come from one linear
clock per GPS stream, t_n = first + n / rate for the n-th sample of the
stream (0-based, counted over the file), as GoPro's gpmf-parser computes it
(``GetGPMFSampleRate`` with ``GPMF_SAMPLE_RATE_PRECISE``):

- with ``STMP`` (HERO8 onwards, MAX; camera microseconds): rate = samples
  between the first and the last GPS payload / their STMP difference;
  first = (the first GPS STMP - the SHUT STMP of that payload) - TIMO + the
  first payload's time on the track's sample table (0 in GoPro files);
- without (HERO5-HERO7): a least-squares line through (end time of each GPS
  payload on the MP4 sample table, samples delivered up to its end); first
  = the line's zero crossing - TIMO.

TIMO is the last GPS payload's, as gpmf-parser reads it.

Spreading each payload's samples evenly over its presentation interval is
50-60 ms off at the first sample (the GPS data of a payload trail its start).
The payload times are gpmf-parser's (``payload_times``): payload k spans
[k, k + 1) x the mean payload duration of the track's sample table, without
the track's edit list (FFmpeg's default would shift a track whose edit
starts inside its first sample by a whole payload, and delay one with an
empty edit): gpmf-parser, which reads the ``edts`` before the track's
``hdlr``, leaves a metadata track's edit list out. Where every payload but
a shorter last one lasts the same (GoPro's sample tables), these are the
sample table's own times.

UTC: GPS9 samples carry their own (days since 2000 + seconds since midnight,
ms). For GPS5, ``GPSU`` is taken as the UTC of the payload's first GPS
sample, as GoPro documents it (written about once a second, with a jitter
of about one sample period): UTC = media time + the median of (GPSU - media
time of the payload's first sample) over the file. That is the only anchor a
GPS5 camera gives, and a loose one: in real HERO11 payloads, whose GPS9
samples carry their own times, GPSU is 1.4 s after the payload's first
sample. The report states the offset, the payloads' spread
around it and this caveat; GPSU more than 0.5 s off the median (stale, as
the first payload often is) are left out and counted. Heights are above MSL when
the stream says ``GPSA`` = ``MSLV``, else above the WGS84 ellipsoid (GPS5 on
HERO5-HERO7). Payloads with ``GPSF`` < 2 (no fix) and GPS9 samples with fix
< 2 are dropped; DOP (``GPSP`` / 100) is kept.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.gpmf import GPMFError, GPSBlock, gps_blocks, klv_items, stream_stamp
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.records import ELLIPSOID, GEODETIC, MSL, LogRecords, check_geodetic, make_records

UNIT = "GPS sample"
NO_FIX = "no fix (GPSF or GPS9 fix < 2)"
DAYS_2000_POSIX = 946684800.0
STALE_GPSU_S = 0.5
RAW_PAYLOAD_S = 1.001  # s: GoPro's metadata payload interval, for raw GPMF streams without their MP4
GPSU_LAG_NOTE = (
    "GPSU is 1.4 s after the payload's first sample on real HERO11 payloads (GPS9 times): this UTC is "
    "good to about 1.5 s"
)


@dataclass(frozen=True)
class SampleClock:
    """Media time of a GPMF stream's samples: t_n = first_s + n / rate_hz (n counted from the stream's first sample)."""

    first_s: float
    rate_hz: float
    method: str  # "STMP" (camera timestamps) or "MP4 sample table" (payload times)

    def times(self, n: np.ndarray) -> np.ndarray:
        return self.first_s + np.asarray(n, dtype=float) / self.rate_hz


@dataclass(frozen=True)
class Payload:
    """What the clock needs of one payload holding GPS samples: its presentation interval on the
    MP4 track (s), its sample count, and its STMP / SHUT STMP (us), TIMO (s) and TSMP when present."""

    start_s: float
    end_s: float
    samples: int
    stmp_us: int | None = None
    base_us: int | None = None
    timo_s: float = 0.0
    tsmp: int | None = None


def _sniff(head: bytes) -> bool:
    return len(head) >= 12 and (head[4:8] == b"ftyp" or head[:4] == b"DEVC")


def read_gopro(path: str | Path) -> LogRecords:
    """Read the GPS samples of a GoPro MP4, or of a raw GPMF stream (``.raw``: payloads back to back); see the module
    notes.
    """
    path = Path(path)
    try:
        with path.open("rb") as handle:
            raw = handle.read(4) == b"DEVC"
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if raw:
        return _raw_records(path)
    return gopro_records(path, metadata_packets(path))


def metadata_packets(path: Path) -> list[tuple[float, float, bytes]]:
    """(start s, duration s, GPMF payload) of each packet of an MP4's GPMF track, timed as gpmf-parser times them
    (``payload_times``; see the module notes); InputError when the file has no such track."""
    import av

    ticks: list[int] = []
    payloads: list[bytes] = []
    timescale = 1.0
    try:
        with av.open(str(path), options={"ignore_editlist": "1"}) as container:
            for stream in container.streams:
                if stream.type != "data":
                    continue
                first = next(iter(container.demux(stream)), None)
                container.seek(0)
                if first is None or not bytes(first).startswith(b"DEVC"):
                    continue
                for packet in container.demux(stream):
                    if packet.pts is None:
                        continue
                    timescale = 1.0 / float(packet.time_base)
                    ticks.append(packet.duration or 0)
                    payloads.append(bytes(packet))
                break
    except av.error.FFmpegError as exc:
        raise InputError(f"{path}: cannot read as MP4: {exc}") from None
    packets = [
        (start, end - start, payload)
        for (start, end), payload in zip(payload_times(ticks, timescale), payloads)
        if payload
    ]
    if not packets:
        raise InputError(
            f"{path}: no GoPro GPMF metadata track (a data stream starting with DEVC); is this a GoPro HERO5-or-later "
            f"video?"
        )
    return packets


def payload_times(durations: list[int], timescale: float) -> list[tuple[float, float]]:
    """(start s, end s) of each payload of a metadata track as gpmf-parser's GetPayloadTime gives them: payload k spans
    [k, k + 1) x the track's base duration, the last one ending at the track's length.

    durations: each payload's duration on the sample table (ticks of 1 / timescale s). The base duration is the
    mean duration of the payloads up to the table's last entry of more than one payload (a last, shorter payload
    does not change it; a first payload of another length does, by its share).
    """
    entries: list[list[int]] = []  # the sample table's (count, duration) entries
    for ticks in durations:
        if entries and entries[-1][1] == ticks:
            entries[-1][0] += 1
        else:
            entries.append([1, ticks])
    length, samples, base = 0.0, 0, 0.0
    for count, ticks in entries:
        samples += count
        length += count * ticks / timescale
        if count > 1 or len(entries) == 1 or base == 0.0:
            base = length * timescale / samples
    return [(k * base / timescale, min((k + 1) * base / timescale, length)) for k in range(len(durations))]


def _raw_records(path: Path) -> LogRecords:
    """A raw GPMF stream (as gopro-telemetry or ffmpeg extract it): its DEVC payloads placed every RAW_PAYLOAD_S on a
    timeline of their own, since the MP4 sample table that timed them is gone (STMP, where present, still does)."""
    data = path.read_bytes()
    try:
        payloads = [
            data[offset - 8 : offset + ((size * repeat + 3) & ~3)]
            for key, _, size, repeat, offset in klv_items(data)
            if key == b"DEVC"
        ]
    except GPMFError as exc:
        raise InputError(f"{path}: raw GPMF: {exc}") from None
    records = gopro_records(path, [(k * RAW_PAYLOAD_S, RAW_PAYLOAD_S, p) for k, p in enumerate(payloads)])
    note = (
        f"a raw GPMF stream ({len(payloads)} payloads): no MP4 sample table, so the payloads are placed every "
        f"{RAW_PAYLOAD_S} s "
        "(GoPro's payload interval); the video's time 0 is not known from this file"
    )
    return replace(
        records,
        notes=(note, *records.notes),
        warnings=(*records.warnings, note),
        video_time_zero=None,
        video_zero_spread_s=None,
    )


def sample_clock(payloads: list[Payload], track_start_s: float) -> SampleClock:
    """The stream's linear sample clock (see the module notes); payloads in order, each with samples > 0.

    track_start_s: the time of the metadata track's first payload on its sample
    table, added to STMP-based times as gpmf-parser adds the track's start.
    """
    first, last = payloads[0], payloads[-1]
    total = sum(p.samples for p in payloads)
    if len(payloads) == 1 or last.end_s <= first.start_s:
        return SampleClock(
            first.start_s - first.timo_s, first.samples / max(first.end_s - first.start_s, 1e-9), "MP4 sample table"
        )
    approx = total / (last.end_s - first.start_s)
    if first.stmp_us is not None and last.stmp_us is not None and last.stmp_us > first.stmp_us:
        # samples delivered between the two STMPs: by TSMP (which also counts samples a payload lost), else counted here
        between = (
            (last.tsmp - last.samples) - (first.tsmp - first.samples)
            if first.tsmp is not None and last.tsmp is not None
            else total - last.samples
        )
        rate = between / ((last.stmp_us - first.stmp_us) * 1e-6)
        if 0.9 * rate < approx < 1.1 * rate:
            base = first.base_us if first.base_us is not None else first.stmp_us
            return SampleClock((first.stmp_us - base) * 1e-6 - last.timo_s + track_start_s, rate, "STMP")
    x = np.array([p.end_s for p in payloads])
    y = np.cumsum([p.samples for p in payloads]).astype(float)
    slope = float(np.sum((x - x.mean()) * (y - y.mean())) / np.sum((x - x.mean()) ** 2))
    if not slope > 0:
        return SampleClock(first.start_s - last.timo_s, approx, "MP4 sample table")
    intercept = float(y.mean() - slope * x.mean())
    return SampleClock(-intercept / slope - last.timo_s, slope, "MP4 sample table")


def gopro_records(path: Path, packets: list[tuple[float, float, bytes]]) -> LogRecords:
    """LogRecords from (start s, duration s, GPMF payload) packets in video time order."""
    streams: dict[bool, list[tuple[int, float, float, GPSBlock, int | None]]] = {False: [], True: []}
    for k, (start, duration, payload) in enumerate(packets):
        try:
            blocks = gps_blocks(payload)
            base = stream_stamp(payload) if any(b.stmp_us is not None for b in blocks) else None
        except GPMFError as exc:
            raise InputError(f"{path}: GPMF packet {k + 1} (at {start:.3f} s): {exc}") from None
        for block in blocks:
            streams[block.nine].append((k, start, start + duration, block, base))
    nine = bool(streams[True])  # GPS9 (HERO11 on) has each sample's UTC: read it, not the GPS5 it duplicates
    entries = streams[nine]
    timed = [e for e in entries if len(e[3].samples)]
    if not timed:
        raise InputError(
            f"{path}: the GPMF track has no GPS5/GPS9 stream (a camera without GPS, or with GPS switched off)"
        )
    notes, warnings = [], []
    clock = sample_clock(
        [Payload(s, e, len(b.samples), b.stmp_us, base, b.timo_s, b.tsmp) for _, s, e, b, base in timed], packets[0][0]
    )
    notes.append(
        f"sample times on the video timeline: t = {clock.first_s:.4f} s + n / {clock.rate_hz:.4f} Hz "
        f"({'camera STMP timestamps' if clock.method == 'STMP' else 'least squares over the MP4 payload times'}, as "
        f"gpmf-parser)"
    )
    rows: list[list[float]] = []
    numbers: list[int] = []
    dops: list[float] = []
    dropped: dict[str, list[int]] = {}
    anchors: list[float] = []
    msl_seen, number = set(), 0
    for _, _, _, block, _ in entries:
        n = len(block.samples)
        media = clock.times(number + np.arange(n))
        ok = np.full(n, block.fix is None or block.fix >= 2)
        if nine:
            ok &= block.samples[:, 8] >= 2
            t = DAYS_2000_POSIX + block.samples[:, 5] * 86400.0 + block.samples[:, 6]
            anchors += (t[ok] - media[ok]).tolist()
        else:
            t = media
            if block.utc is not None and ok.any():
                anchors.append(block.utc - media[0])
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
            dops.append(block.samples[i, 7] if nine else (block.dop if block.dop is not None else np.nan))
    utc = bool(anchors)
    media_to_utc, spread = None, None
    if anchors:
        a = np.asarray(anchors)
        media_to_utc = float(np.median(a))
        off = np.abs(a - media_to_utc)
        stale = off > STALE_GPSU_S
        spread = float(off[~stale].max())
        zero = (
            dt.datetime.fromtimestamp(media_to_utc, dt.timezone.utc)
            .isoformat(timespec="milliseconds")
            .replace("+00:00", "Z")
        )
        if nine:
            notes.append(
                f"UTC from each GPS9 sample's own time; video time 0 is {zero} (the samples within {spread:.3f} s of "
                f"one offset)"
            )
        else:
            notes.append(
                f"UTC = video time + the median of (GPSU - the payload's first sample time) over "
                f"{int((~stale).sum())} payloads: "
                f"video time 0 is {zero} (the payloads spread by up to {spread:.3f} s; {GPSU_LAG_NOTE})"
            )
            if stale.any():
                warnings.append(
                    f"{int(stale.sum())} payload(s) with a GPSU more than {STALE_GPSU_S:g} s off the others (stale, "
                    f"as GoPros write before the time settles): not used for UTC"
                )
            rows = (np.asarray(rows).reshape(-1, 4) + [media_to_utc, 0.0, 0.0, 0.0]).tolist()
    elif rows:
        warnings.append(
            "no GPSU in the GPS stream: times are the video's presentation times; offsets work, UTC does not"
        )
    if len(msl_seen) > 1:
        warnings.append("the GPS stream changes its altitude system (GPSA) mid-file: heights mix MSL and ellipsoid")
    altitude = MSL if True in msl_seen and False not in msl_seen else ELLIPSOID
    return make_records(
        path,
        "gopro",
        GEODETIC,
        rows,
        numbers,
        unit=UNIT,
        utc=utc,
        dropped=dropped,
        warnings=warnings,
        altitude=altitude,
        quality={"dop": dops},
        clock=None if utc else "video presentation time (s)",
        notes=notes,
        video_time_zero=media_to_utc if utc else 0.0,
        video_zero_spread_s=spread,
    )


READER = Reader(
    "gopro", "GoPro MP4 with a GPMF track (bytes 4-7 'ftyp') or a raw GPMF stream (starting 'DEVC')", read_gopro, _sniff
)
