"""GoPro's sample clock without STMP (HERO5-HERO7) on a real MP4 against gpmf-parser, also with an edited MP4 box.

gpmf-parser's ``karma.mp4`` (a GoPro Karma drone's HERO5-era recording: no STMP, no GPS, but accelerometer, gyro
and shutter streams timed the way a HERO7's GPS5 is) is read four ways: as it is, with an empty edit of one
frame (33.4 ms) put into its metadata track's ``edts``, with an edit that starts 33 ms into the track's media,
and with a sample table whose first payload lasts 1.034 s instead of 1.001 s. For each, and each stream with
one sample array per payload, the sample clock tlsync computes (tlsync_pipeline.ingest.gopro.sample_clock over
the payloads metadata_packets times) is compared with gpmf-parser's demo (``-s``: GetGPMFSampleRate, precise):
rate and first sample time. The edited copies are written to a temporary folder; nothing is committed.

    GPMF_DEMO=.../gpmfdemo python bench/gopro_clock.py   (karma.mp4 under $TLSYNC_REAL_LOGS, default
                                                         /tmp/tlsync_real_logs; the demo built as
                                                         bench/ingest_formats.py says)
"""

from __future__ import annotations

import os
import re
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tlsync_pipeline.ingest.gopro import Payload, metadata_packets, sample_clock  # noqa: E402
from tlsync_pipeline.ingest.gpmf import klv_items  # noqa: E402

REAL = Path(os.environ.get("TLSYNC_REAL_LOGS", "/tmp/tlsync_real_logs"))
STREAMS = ("ACCL", "GYRO", "SHUT", "ISOG")
EDITS = {  # name -> the change: elst entries (segment duration in the movie's 90 kHz, media time in the track's
    # 1 kHz, rate) or stts entries (payloads, duration in the track's 1 kHz)
    "as recorded": None,
    "an empty edit of 33.4 ms": ("elst", [(3003, -1, 65536), (1171170, 0, 65536)]),
    "an edit from 33 ms into the media": ("elst", [(1171170, 33, 65536)]),
    "a first payload of 1.034 s (stts)": ("stts", [(1, 1034), (12, 1001)]),
}


def _boxes(data: bytes, start: int, end: int):
    offset = start
    while offset + 8 <= end:
        size, kind = struct.unpack(">I4s", data[offset : offset + 8])
        yield kind, offset, size
        offset += size


def _met_track(data: bytes) -> tuple[int, int, int]:
    """(moov offset, GoPro MET trak offset, trak size)."""
    moov = next(offset for kind, offset, _ in _boxes(data, 0, len(data)) if kind == b"moov")
    moov_size = struct.unpack(">I", data[moov : moov + 4])[0]
    for kind, trak, size in _boxes(data, moov + 8, moov + moov_size):
        if kind == b"trak" and b"GoPro MET" in data[trak : trak + size]:
            return moov, trak, size
    raise ValueError("no GoPro MET track")


def _insert(data: bytes, at: int, remove: int, insert: bytes, parents: list[int]) -> bytes:
    """data with ``remove`` bytes at ``at`` replaced by ``insert``, the sizes of the boxes at ``parents`` adjusted
    (the moov must follow the mdat, so no chunk offset moves)."""
    out = bytearray(data[:at] + insert + data[at + remove :])
    for box in parents:
        out[box : box + 4] = struct.pack(">I", struct.unpack(">I", out[box : box + 4])[0] + len(insert) - remove)
    return bytes(out)


def with_edit_list(data: bytes, entries: list[tuple[int, int, int]]) -> bytes:
    """The MP4 with an ``edts`` put into its GoPro MET track after the ``tkhd``."""
    moov, trak, _ = _met_track(data)
    tkhd_end = trak + 8 + struct.unpack(">I", data[trak + 8 : trak + 12])[0]
    elst = struct.pack(">I4sII", 16 + 12 * len(entries), b"elst", 0, len(entries))
    elst += b"".join(struct.pack(">IiI", *entry) for entry in entries)
    return _insert(data, tkhd_end, 0, struct.pack(">I4s", 8 + len(elst), b"edts") + elst, [moov, trak])


def with_sample_table(data: bytes, entries: list[tuple[int, int]]) -> bytes:
    """The MP4 with its GoPro MET track's ``stts`` (count, duration) entries replaced."""
    moov, trak, size = _met_track(data)
    parents = [moov, trak]
    start, end = trak + 8, trak + size
    for name in (b"mdia", b"minf", b"stbl"):
        box, box_size = next((offset, s) for kind, offset, s in _boxes(data, start, end) if kind == name)
        parents.append(box)
        start, end = box + 8, box + box_size
    stts, stts_size = next((offset, s) for kind, offset, s in _boxes(data, start, end) if kind == b"stts")
    table = struct.pack(">I4sII", 16 + 8 * len(entries), b"stts", 0, len(entries))
    table += b"".join(struct.pack(">II", *entry) for entry in entries)
    return _insert(data, stts, stts_size, table, parents)


def _samples(payload: bytes, fourcc: bytes) -> int:
    """Samples of fourcc in a payload (0 when absent), over every nesting level."""
    total = 0
    for key, kind, size, repeat, offset in klv_items(payload):
        if kind == 0:
            total += _samples(payload[offset : offset + size * repeat], fourcc)
        elif key == fourcc:
            total += repeat
    return total


def tlsync_clocks(path: Path) -> dict[str, tuple[float, float]]:
    packets = metadata_packets(path)
    clocks = {}
    for name in STREAMS:
        payloads = [Payload(s, s + d, n) for s, d, p in packets if (n := _samples(p, name.encode()))]
        if payloads:
            clock = sample_clock(payloads, packets[0][0])
            clocks[name] = (clock.rate_hz, clock.first_s)
    return clocks


def reference_clocks(demo: str, path: Path) -> dict[str, tuple[float, float]]:
    text = subprocess.run([demo, str(path), "-s"], capture_output=True, check=True).stdout.decode("latin-1")
    found = re.findall(r"(\w{4}) sampling rate = ([\d.]+)Hz \(time (-?[\d.]+) to", text)
    return {name: (float(rate), float(first)) for name, rate, first in found if name in STREAMS}


def main() -> None:
    demo, karma = os.environ.get("GPMF_DEMO"), REAL / "karma.mp4"
    if not demo or not Path(demo).exists() or not karma.exists():
        print(f"skipped: needs $GPMF_DEMO and {karma} (gopro/gpmf-parser samples/karma.mp4)")
        return
    print("| metadata track | stream | gpmf-parser rate (Hz), first (s) | tlsync - gpmf-parser: rate, first |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        for name, change in EDITS.items():
            path = karma if change is None else Path(folder) / "edited.mp4"
            if change is not None:
                box, entries = change
                edit = with_edit_list if box == "elst" else with_sample_table
                path.write_bytes(edit(karma.read_bytes(), entries))
            ours, reference = tlsync_clocks(path), reference_clocks(demo, path)
            for stream, (rate, first) in reference.items():
                d_rate, d_first = ours[stream][0] - rate, ours[stream][1] - first
                print(f"| {name} | {stream} | {rate:.6f}, {first:.6f} | {d_rate:+.1e}, {d_first * 1e6:+.2f} us |")


if __name__ == "__main__":
    main()
