"""Streaming video reading with PyAV: frame index, presentation time, pixels.

Frames are numbered 0, 1, 2, ... in presentation order as the decoder emits
them; the presentation time is ``frame.pts * time_base`` in seconds, read from
the container (not derived from a nominal frame rate, so variable-frame-rate
video keeps its true times). Frames are returned as displayed: rotation
metadata (display matrix) is applied. Memory stays flat: one frame at a time.

A file that stops decoding part-way (truncated, corrupt) is read up to its
last decodable frame with a ``TruncatedVideoWarning`` naming that frame.
"""

from __future__ import annotations

import math
import queue
import stat
import struct
import threading
import warnings
from bisect import bisect_right
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from trackers.errors import TrackInputError


class TruncatedVideoWarning(UserWarning):
    """A video stopped decoding before its announced end: ``frames_read`` of ``frames_announced``
    (0: unknown) frames.
    """

    def __init__(self, message: str, frames_read: int = 0, frames_announced: int = 0):
        super().__init__(message)
        self.frames_read = frames_read
        self.frames_announced = frames_announced


class VideoFrame(NamedTuple):
    """One decoded frame: 0-based index, presentation time (s), image (H, W[, 3]) uint8 BGR or grey."""

    index: int  # type: ignore[assignment]  # the field's name shadows tuple.index, which nothing here calls
    time_s: float
    image: np.ndarray


@dataclass(frozen=True)
class VideoInfo:
    """What the container says about a video stream.

    width, height: displayed size in pixels (after rotation); n_frames: the
    container's frame count (0 when unknown, an estimate from the duration
    when the container does not store it; counted: the count is stored by
    the container); fps: average frame rate; rotation: counter-clockwise
    degrees applied to decoded frames.
    """

    path: Path
    width: int
    height: int
    n_frames: int
    fps: float
    rotation: int
    codec: str
    counted: bool


def probe_video(path: str | Path) -> VideoInfo:
    """Open a video and describe its first video stream; TrackInputError if it cannot be read.

    Reads the container's metadata only; decodes the first frame only when
    the rotation is not stored where it can be read without decoding (the
    MP4/MOV track header: _stored_rotation).
    """
    path = Path(path)
    with _open(path, demux_only=True) as container:
        stream = container.streams.video[0]
        rotation = _stored_rotation(path, container, stream)
        if rotation is not None:
            return _info(path, stream, rotation)
    with _open(path) as container:
        stream = container.streams.video[0]
        return _info(path, stream, _first_rotation(path, container, stream))


def iter_frames(
    path: str | Path, gray: bool = False, progress: bool = False, desc: str | None = None
) -> Iterator[VideoFrame]:
    """Yield every decodable frame of ``path`` in order, with its index and presentation time.

    gray: yield (H, W) grey frames instead of (H, W, 3) BGR (for YUV video
    the decoder's luma plane as stored, usually 16-235). progress: a
    tqdm bar (frames, frames/s, ETA). A video without any decodable frame
    raises TrackInputError; one that stops early warns (TruncatedVideoWarning).
    Frames are decoded up to READ_AHEAD frames ahead in a thread of their own
    (``_decode_ahead``), so decoding overlaps the caller's work.
    """
    path = Path(path)
    with _open(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        info = _info(path, stream, None)
        bar = _progress_bar(info.n_frames, desc or path.name) if progress else None
        index = -1
        rotation = None
        last_time = None
        try:
            for frame, error in _decode_ahead(container, stream):
                if error is not None:
                    _warn_truncated(path, index, last_time, info.n_frames, error)
                    break
                index += 1
                if rotation is None:
                    rotation = _rotation(frame, stream)
                last_time = _time(frame, stream, index, info.fps)
                yield VideoFrame(index, last_time, _to_array(frame, gray, rotation))
                if bar is not None:
                    bar.update(1)
            else:
                if index >= 0 and info.n_frames and index + 1 < info.n_frames and stream.frames:
                    _warn_truncated(path, index, last_time, info.n_frames, "end of file")
        finally:
            if bar is not None:
                bar.close()
        if index < 0:
            raise TrackInputError(f"{path}: the video has no decodable frame")


def read_frames(path: str | Path, indices: Iterable[int], gray: bool = False) -> dict[int, VideoFrame]:
    """Decode only the frames at ``indices`` (0-based): seek to the keyframe before each, decode forward.

    A demux-only pass over the packets (no decoding) maps frame indices to
    presentation timestamps, so indices agree with ``iter_frames``. Indices
    past the end raise TrackInputError.
    """
    path = Path(path)
    wanted = sorted(set(int(i) for i in indices))
    if not wanted:
        return {}
    if wanted[0] < 0:
        raise TrackInputError(f"{path}: frame index {wanted[0]} is negative; frames are 0-based")
    pts_list, keyframes = _packet_index(path)
    if pts_list is None:  # timestamps unknown: decode from the start, keep the wanted ones
        return _read_sequential(path, wanted, gray)
    if wanted[-1] >= len(pts_list):
        raise TrackInputError(f"{path}: frame {wanted[-1]} is past the end of the video ({len(pts_list)} frames)")
    return _read_indexed(path, wanted, gray, pts_list, keyframes)


def _read_indexed(
    path: Path, wanted: list[int], gray: bool, pts_list: tuple[int, ...], keyframes: tuple[int, ...]
) -> dict[int, VideoFrame]:
    """read_frames with the video's packet index (_packet_index) at hand: ``wanted`` sorted, within the video.

    Between the wanted frames the decoder skips the frames no other frame is predicted from (FFmpeg's
    ``skip_frame = NONREF``: a quarter of the CPU of an H.264 run-up with B-frames); the wanted frames are decoded
    as always, so they come out identical. Before each seek, once the packets of the wanted frames decoded from that
    keyframe are sent, the decoder is drained (as ``_read_keyframes`` does) instead of fed the next packets for
    its frame threads' and reordering delay (about five frames decoded for nothing)."""
    out: dict[int, VideoFrame] = {}
    needed = {pts_list[i] for i in wanted}
    targets = [pts_list[i] for i in wanted]
    starts = [keyframes[max(0, bisect_right(keyframes, t) - 1)] if keyframes else pts_list[0] for t in targets]
    with _open(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        fps = _fps(stream)
        rotation = None
        position = None  # pts of the last decoded frame, when decoding can continue from it
        frames: Iterator[tuple[Any, str | None]] = iter(())
        for k, i in enumerate(wanted):
            target, start = targets[k], starts[k]
            if position is None or not (start <= position < target):
                container.seek(start, stream=stream, backward=True, any_frame=False)
                last = k  # the wanted frames decoded on from this keyframe: the next ones within reach of it
                while last + 1 < len(wanted) and starts[last + 1] <= targets[last]:
                    last += 1
                frames = _decode(container, stream, needed, drain_after=set(targets[k : last + 1]))
            for frame, error in frames:
                if error is not None:
                    raise TrackInputError(f"{path}: frame {i} cannot be decoded: {error}")
                if frame.pts is None or frame.pts < target:
                    continue
                if frame.pts > target:
                    raise TrackInputError(f"{path}: frame {i} (pts {target}) not found after seeking")
                if rotation is None:
                    rotation = _rotation(frame, stream)
                out[i] = VideoFrame(i, _time(frame, stream, i, fps), _to_array(frame, gray, rotation))
                position = frame.pts
                break
            else:
                raise TrackInputError(f"{path}: frame {i} cannot be decoded (the video ends early)")
    return out


def _read_keyframes(path: Path, targets: list[int], gray: bool) -> list[np.ndarray]:
    """The keyframes at presentation timestamps ``targets`` (sorted), each decoded alone.

    After each seek only the keyframe's packet is decoded, then the decoder
    is drained: it returns the frame at once, where decoding on would feed it
    the next packets first (its frame threads' and reordering delay: about
    five packets a frame at 1080p). The next seek resets the decoder.
    TrackInputError when a keyframe is not where the packet index put it.
    """
    import av

    out = []
    with _open(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        rotation = None
        for target in targets:
            container.seek(target, stream=stream, backward=True, any_frame=False)
            frame = None
            try:
                for packet in container.demux(stream):
                    if packet.pts is None or packet.size == 0:
                        continue
                    if packet.pts == target:
                        frame = next((f for f in _decode_alone(stream, packet) if f.pts == target), None)
                        break
                    if packet.is_keyframe and packet.pts > target:
                        break
            except av.FFmpegError as exc:
                raise TrackInputError(f"{path}: the keyframe at pts {target} cannot be decoded: {exc}") from None
            if frame is None:
                raise TrackInputError(f"{path}: the keyframe at pts {target} not found after seeking")
            if rotation is None:
                rotation = _rotation(frame, stream)
            out.append(_to_array(frame, gray, rotation))
    return out


@dataclass
class DecodeCount:
    """Frames a reading function decoded (``decoded``) and handed to its caller (``yielded``), filled in as it reads."""

    decoded: int = 0
    yielded: int = 0


def keyframe_indices(path: str | Path) -> np.ndarray | None:
    """0-based frame indices (as ``iter_frames`` numbers them) of the video's keyframes, demux only; None without
    timestamps.
    """
    pts_list, keyframes = _packet_index(Path(path))
    if not pts_list:
        return None
    where = {pts: i for i, pts in enumerate(pts_list)}
    return np.array(sorted(where[k] for k in keyframes if k in where), dtype=np.int64)


def frame_count(path: str | Path) -> int | None:
    """Frames in the video by its packet index (demux only), None without timestamps."""
    pts_list, _ = _packet_index(Path(path))
    return len(pts_list) if pts_list else None


def iter_keyframes(
    path: str | Path,
    gray: bool = True,
    count: DecodeCount | None = None,
    indices: Iterable[int] | None = None,
    decoded: dict[int, np.ndarray] | None = None,
) -> Iterator[VideoFrame]:
    """Every keyframe of ``path`` (or those at the 0-based frame ``indices``) in order, with its index and presentation
    time, each decoded alone.

    The packets are demuxed in order (no seeking) and only keyframes' are
    decoded, each on its own: the decoder is drained after it and reset
    (``flush_buffers``), so no other frame is ever decoded. A keyframe costs
    about five average frames of H.264: at one every 60 frames this reads
    the video for about a tenth of decoding it all. decoded: images already
    decoded (as ``gray`` asks) by frame index, yielded instead of decoding
    their packets again (a keyframe decodes to the same image alone or after
    a seek); count.decoded counts only what is decoded here. TrackInputError
    when the video has no packet index (no timestamps) or a keyframe cannot
    be decoded.
    """
    import av

    path = Path(path)
    pts_list, keys = _packet_index(path)
    if not pts_list:
        raise TrackInputError(f"{path}: the video has no timestamps to index its keyframes by")
    where = {pts: i for i, pts in enumerate(pts_list)}
    wanted = set(keys) if indices is None else {pts_list[i] for i in indices if 0 <= i < len(pts_list)}
    with _open(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        fps = _fps(stream)
        rotation = None
        try:
            for packet in container.demux(stream):
                if packet.pts is None or packet.size == 0 or packet.pts not in wanted:
                    continue
                index = where[packet.pts]
                if decoded is not None and index in decoded:
                    if count is not None:
                        count.yielded += 1
                    yield VideoFrame(index, _packet_time(packet, stream), decoded[index])
                    continue
                frames = _decode_alone(stream, packet)
                stream.codec_context.flush_buffers()
                for frame in frames:
                    if frame.pts != packet.pts:
                        continue
                    if count is not None:
                        count.decoded += 1
                        count.yielded += 1
                    if rotation is None:
                        rotation = _rotation(frame, stream)
                    index = where[frame.pts]
                    yield VideoFrame(index, _time(frame, stream, index, fps), _to_array(frame, gray, rotation))
        except av.FFmpegError as exc:
            raise TrackInputError(f"{path}: a keyframe cannot be decoded: {exc}") from None


def merge_windows(windows: Iterable[tuple[int, int]], gap: int = 0) -> list[tuple[int, int]]:
    """Frame windows [start, stop) (0-based, stop excluded) sorted and merged where they overlap or lie within ``gap``
    frames.
    """
    out: list[list[int]] = []
    for start, stop in sorted((int(a), int(b)) for a, b in windows if int(b) > int(a)):
        if out and start <= out[-1][1] + gap:
            out[-1][1] = max(out[-1][1], stop)
        else:
            out.append([start, stop])
    return [(a, b) for a, b in out]


def iter_windows(
    path: str | Path,
    windows: Iterable[tuple[int, int]],
    gray: bool = False,
    progress: bool = False,
    desc: str | None = None,
    count: DecodeCount | None = None,
) -> Iterator[VideoFrame]:
    """Every frame of ``path`` inside the windows [start, stop) (0-based frame indices, stop excluded), in order.

    Each window is read by seeking to the keyframe at or before its start and
    decoding forward to its end (frames between the keyframe and the start
    are decoded, not yielded); indices and presentation times are those of
    ``iter_frames`` (the packet index maps each decoded frame's timestamp to
    its index). Windows are merged first (``merge_windows``) and clipped to
    the video. Decoding runs ahead in a thread of its own, as in
    ``iter_frames``. A video without timestamps raises TrackInputError; a
    frame that cannot be decoded ends the reading with a
    TruncatedVideoWarning naming the last frame read.
    """
    path = Path(path)
    pts_list, keyframes = _packet_index(path)
    if not pts_list:
        raise TrackInputError(f"{path}: the video has no timestamps to seek by")
    n = len(pts_list)
    plan = [(a, min(b, n)) for a, b in merge_windows(windows) if a < n]
    where = {pts: i for i, pts in enumerate(pts_list)}
    with _open(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        fps = _fps(stream)
        bar = _progress_bar(sum(b - a for a, b in plan), desc or path.name) if progress else None
        rotation = None
        last: tuple[int, float | None] = (-1, None)
        try:
            for item in _ahead(_decode_windows(container, stream, plan, pts_list, keyframes, where)):
                frame, index, error = item
                if error is not None:
                    _warn_truncated(path, last[0], last[1], n, error)
                    return
                if count is not None:
                    count.decoded += 1
                if index is None:
                    continue
                if rotation is None:
                    rotation = _rotation(frame, stream)
                time_s = _time(frame, stream, index, fps)
                last = (index, time_s)
                if count is not None:
                    count.yielded += 1
                yield VideoFrame(index, time_s, _to_array(frame, gray, rotation))
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()


def _decode_windows(
    container, stream, plan, pts_list, keyframes, where
) -> Iterator[tuple[Any, int | None, str | None]]:
    """(frame, its index when inside the window being read else None, error) for every frame decoded to read ``plan``'s
    windows.
    """
    for start, stop in plan:
        seek_to = keyframes[max(0, bisect_right(keyframes, pts_list[start]) - 1)] if keyframes else pts_list[0]
        container.seek(seek_to, stream=stream, backward=True, any_frame=False)
        for frame, error in _decode(container, stream):
            if error is not None:
                yield None, None, error
                return
            index = where.get(frame.pts) if frame.pts is not None else None
            if index is None or index < start:
                yield frame, None, None
                continue
            if index >= stop:
                break
            yield frame, index, None
            if index == stop - 1:
                break


def _decode_alone(stream, packet) -> list:
    """The frames of one packet decoded on its own: the packet sent, then the decoder drained (until the next seek)."""
    return list(stream.decode(packet)) + list(stream.decode(None))


def presentation_times(path: str | Path) -> np.ndarray | None:
    """Presentation time (s) of every frame, indexed as ``iter_frames`` numbers them (demux only, no decoding).

    None when the container has no timestamps.
    """
    path = Path(path)
    pts_list, _ = _packet_index(path)
    if not pts_list:
        return None
    with _open(path, demux_only=True) as container:
        base = Fraction(container.streams.video[0].time_base or Fraction(1, 1))
    return seconds_of(np.array(pts_list, dtype=np.int64), base)


def seconds_of(pts: np.ndarray, base: Fraction) -> np.ndarray:
    """Timestamps (int64) times ``base`` in seconds, each the float nearest the exact product (``float(pts * base)``):
    with every product and the denominator below 2**53 one division of exact floats, correctly rounded."""
    exact = 2**53
    if len(pts) == 0 or (int(np.abs(pts).max()) < exact // max(abs(base.numerator), 1) and base.denominator < exact):
        return (pts * base.numerator) / base.denominator
    return np.array([float(int(p) * base) for p in pts])


def packet_sizes(path: str | Path) -> tuple[np.ndarray, np.ndarray] | None:
    """Bytes of every frame's packet and whether it is a keyframe, indexed as ``iter_frames`` numbers the frames
    (demux only, no decoding: the same pass as ``presentation_times``).

    None when the container has no timestamps.
    """
    path = Path(path)
    pts_list, keys = _packet_index(path)
    if not pts_list:
        return None
    stat_ = path.stat()
    sizes = _index_packets(path, (stat_.st_size, stat_.st_mtime_ns))[2]
    return np.array(sizes, dtype=np.int64), np.isin(np.array(pts_list), np.array(keys))


def _read_sequential(path: Path, wanted: list[int], gray: bool) -> dict[int, VideoFrame]:
    out = {}
    remaining = set(wanted)
    for frame in iter_frames(path, gray=gray):
        if frame.index in remaining:
            out[frame.index] = frame
            remaining.discard(frame.index)
            if not remaining:
                return out
    raise TrackInputError(f"{path}: frame {min(remaining)} is past the end of the video")


def _packet_index(path: Path) -> tuple[tuple[int, ...] | None, tuple[int, ...]]:
    """Sorted presentation timestamps of the video packets, and those of keyframes (demux only).

    Kept for the video as it is (path, size, modification time): a process
    that reads a video's frames and its times demuxes it once.
    """
    if not path.is_file():
        return _index_packets(path, None)[:2]  # _open names what is wrong
    stat = path.stat()
    return _index_packets(path, (stat.st_size, stat.st_mtime_ns))[:2]


@lru_cache(maxsize=16)
def _index_packets(
    path: Path, stamp: tuple[int, int] | None
) -> tuple[tuple[int, ...] | None, tuple[int, ...], tuple[int, ...]]:
    """``_packet_index`` of ``path``, whose (size, modification time) is ``stamp``, and the packets' sizes (bytes)
    in the order of their presentation timestamps."""
    import av

    pts, keys, sizes = [], [], []
    with _open(path, demux_only=True) as container:
        stream = container.streams.video[0]
        try:
            for packet in container.demux(stream):
                size = packet.size
                if size == 0:
                    continue
                if packet.pts is None:
                    return None, (), ()
                pts.append(packet.pts)
                sizes.append(size)
                if packet.is_keyframe:
                    keys.append(packet.pts)
        except av.FFmpegError:
            pass  # truncated: index what could be read
    order = sorted(range(len(pts)), key=pts.__getitem__)
    return tuple(pts[k] for k in order), tuple(sorted(keys)), tuple(sizes[k] for k in order)


# Codec options of the stream probe (``avformat_find_stream_info``) for a container read without decoding: it decodes
# no frame (an H.264 probe decodes the first keyframe and more, about 12 ms at 720p an open).
_PROBE_WITHOUT_DECODING = {"skip_frame": "all"}


def _open(path: Path, demux_only: bool = False):
    """The video opened with PyAV (imported here: 0.1 s that processes which never read a video do not pay).

    demux_only: for reading the container's metadata and packets, no frame: an MP4/MOV file is then opened without
    the stream probe's decoding (its sizes, frame count, rates and time base are the container's, the same either
    way); other containers are opened in full (their rates may come from the probe's frames).
    """
    if not path.exists():
        raise TrackInputError(f"{path}: file not found")
    if path.is_dir():
        raise TrackInputError(f"{path}: is a folder, expected a video file")
    if not stat.S_ISREG(path.stat().st_mode) or path.resolve().parts[1:2] in (("proc",), ("sys",), ("dev",)):
        raise TrackInputError(
            f"{path}: not a regular file (a device, a pipe or a file of the system), expected a video file"
        )
    if demux_only:
        container = _open_container(path, _PROBE_WITHOUT_DECODING)
        if _ISO_MEDIA & set(container.format.name.split(",")):
            return container
        container.close()
    return _open_container(path, None)


def _open_container(path: Path, options: dict[str, str] | None):
    import av

    try:
        container = av.open(str(path), mode="r", options=options)
    except av.error.EOFError:
        raise TrackInputError(f"{path}: the file ends before any video frame (an empty or truncated video)") from None
    except (av.FFmpegError, OSError, UnicodeDecodeError) as exc:
        raise TrackInputError(f"{path}: not a readable video file ({exc})") from None
    if not container.streams.video:
        container.close()
        raise TrackInputError(f"{path}: the file has no video stream")
    return container


def _decode(
    container, stream, needed: set[int] | None = None, drain_after: set[int] | None = None
) -> Iterator[tuple[Any, str | None]]:
    """Decoded frames; stops with (None, reason) at the first demux or decode error.

    needed: the presentation timestamps of the frames wanted; the frames of other packets are decoded only where
    a later frame is predicted from them (non-reference frames are skipped). None: every frame. drain_after: once
    the packets of these presentation timestamps are sent (in decoding order, a frame's packet may come after a later
    frame's), the decoder is drained and no further packet read: their frames come out without the decoder's delay;
    decoding on needs a seek first.
    """
    import av

    left = set(drain_after) if drain_after else None
    packets = container.demux(stream)
    while True:
        try:
            packet = next(packets)
        except StopIteration:
            return
        except av.FFmpegError as exc:
            yield None, str(exc)
            return
        if needed is not None:
            stream.codec_context.skip_frame = "DEFAULT" if packet.pts in needed else "NONREF"
        if left is not None:
            left.discard(packet.pts)
        drain = left is not None and not left
        try:
            frames = list(packet.decode()) + (list(stream.decode(None)) if drain else [])
        except av.FFmpegError as exc:
            yield None, str(exc)
            return
        for frame in frames:
            yield frame, None
        if drain:
            return


READ_AHEAD = 4  # frames decoded ahead of the caller by iter_frames
_END = object()


def _decode_ahead(container, stream) -> Iterator[tuple[Any, str | None]]:
    """``_decode``'s items, decoded in a background thread up to READ_AHEAD frames ahead (``_ahead``)."""
    return _ahead(_decode(container, stream))


def _ahead(source: Iterator) -> Iterator:
    """``source``'s items, produced in a background thread up to READ_AHEAD items ahead.

    FFmpeg releases the GIL while it decodes, so the next frames decode while
    the caller works on this one (a tracker's detector), on another core when
    one is free. The thread stops, and is joined, when the caller stops
    iterating; its exceptions are raised in the caller.
    """
    items: queue.Queue = queue.Queue(READ_AHEAD)
    stop = threading.Event()

    def put(item) -> bool:
        while not stop.is_set():
            try:
                items.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def produce() -> None:
        try:
            for item in source:
                if not put(item):
                    return
            put(_END)
        except BaseException as exc:  # handed to the caller, which raises it
            put(exc)

    thread = threading.Thread(target=produce, name="decode-ahead", daemon=True)
    thread.start()
    try:
        while (item := items.get()) is not _END:
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:
        stop.set()
        thread.join()


def _warn_truncated(path: Path, index: int, time_s: float | None, n_frames: int, why: str) -> None:
    if index < 0:
        raise TrackInputError(f"{path}: the video has no decodable frame ({why})")
    announced = f" of {n_frames} announced" if n_frames else ""
    message = (
        f"{path}: video truncated or corrupt ({why}); read up to frame {index} (t = {time_s:.3f} s), "
        f"{index + 1} frames{announced}"
    )
    warnings.warn(TruncatedVideoWarning(message, index + 1, n_frames), stacklevel=3)


def _info(path: Path, stream, rotation: int | None) -> VideoInfo:
    fps = _fps(stream)
    n = int(stream.frames or 0)
    if n == 0 and stream.duration and stream.time_base and fps:
        n = int(round(float(stream.duration * stream.time_base) * fps))
    width, height = stream.codec_context.width, stream.codec_context.height
    rotation = rotation or 0
    if rotation % 180:
        width, height = height, width
    return VideoInfo(path, width, height, n, fps, rotation, stream.codec_context.name, bool(stream.frames))


def _first_rotation(path: Path, container, stream) -> int:
    """Rotation of the first decodable frame (display matrix side data or 'rotate' tag)."""
    stream.thread_type = "AUTO"
    for frame, error in _decode(container, stream):
        if error is not None:
            break
        return _rotation(frame, stream)
    raise TrackInputError(f"{path}: the video has no decodable frame")


_ISO_MEDIA = {"mov", "mp4", "m4a", "3gp", "3g2", "mj2"}  # FFmpeg's names of the ISO base media (MP4/MOV) demuxer
_BOX_HEADER = struct.Struct(">I4s")


def _stored_rotation(path: Path, container, stream) -> int | None:
    """Counter-clockwise rotation (degrees, multiple of 90) from the display matrix of the stream's MP4/MOV track
    header (tkhd), as FFmpeg applies it to decoded frames; None for other containers or a header not found."""
    if not _ISO_MEDIA & set(container.format.name.split(",")) or stream.metadata.get("rotate"):
        return None
    try:
        with path.open("rb") as handle:
            matrix = _track_matrix(handle, int(stream.id))
    except (OSError, struct.error):
        return None
    if matrix is None:
        return None
    a, b, c, d = (v / 65536.0 for v in (matrix[0], matrix[1], matrix[3], matrix[4]))
    if not (math.hypot(a, c) and math.hypot(b, d)):
        return None
    angle = -math.degrees(math.atan2(b / math.hypot(b, d), a / math.hypot(a, c)))  # FFmpeg's av_display_rotation_get
    return int(round(angle / 90.0)) % 4 * 90


def _boxes(handle, start: int, end: int) -> Iterator[tuple[bytes, int, int]]:
    """(type, payload start, payload end) of the ISO media boxes between byte offsets ``start`` and ``end``."""
    position = start
    while position + 8 <= end:
        handle.seek(position)
        size, kind = _BOX_HEADER.unpack(handle.read(8))
        header = 8
        if size == 1:
            size, header = struct.unpack(">Q", handle.read(8))[0], 16
        elif size == 0:
            size = end - position
        if size < header:
            return
        yield kind, position + header, min(position + size, end)
        position += size


def _track_matrix(handle, track_id: int) -> list[int] | None:
    """The 3x3 display matrix (9 integers, row-major, 16.16 and 2.30 fixed point) of track ``track_id``'s tkhd box."""
    handle.seek(0, 2)
    for kind, start, end in _boxes(handle, 0, handle.tell()):
        if kind != b"moov":
            continue
        for trak, trak_start, trak_end in _boxes(handle, start, end):
            if trak != b"trak":
                continue
            for tkhd, at, _ in _boxes(handle, trak_start, trak_end):
                if tkhd != b"tkhd":
                    continue
                handle.seek(at)
                version = handle.read(1)[0]
                ids_at = at + (20 if version == 1 else 12)  # version, flags, creation and modification times
                handle.seek(ids_at)
                if struct.unpack(">I", handle.read(4))[0] != track_id:
                    break
                handle.seek(
                    ids_at + 4 + 4 + (8 if version == 1 else 4) + 16
                )  # track id, reserved, duration, reserved, layer...volume
                return list(struct.unpack(">9i", handle.read(36)))
        return None
    return None


def _rotation(frame, stream) -> int:
    """Counter-clockwise rotation in degrees (multiple of 90) that displays the frame upright."""
    angle = frame.rotation or 0
    if not angle:
        tag = stream.metadata.get("rotate")
        try:
            angle = -int(float(tag)) if tag else 0  # the legacy tag counts clockwise
        except ValueError:
            angle = 0
    return int(round(angle / 90.0)) % 4 * 90


# Formats whose first plane is 8-bit luma: grey frames are a copy of it (no colour conversion).
_LUMA_FIRST = {"yuv420p", "yuvj420p", "yuv422p", "yuvj422p", "yuv444p", "yuvj444p", "nv12", "nv21", "gray"}


def _to_array(frame, gray: bool, rotation: int) -> np.ndarray:
    import cv2

    if gray and frame.format.name in _LUMA_FIRST:
        plane = frame.planes[0]
        image = np.frombuffer(plane, np.uint8).reshape(-1, plane.line_size)[: frame.height, : frame.width]
        if plane.line_size == frame.width and not rotation:
            image.flags.writeable = (
                False  # the decoder's own buffer (kept alive by the array), which it may still predict from
            )
            return image
        image = image.copy()
    elif (
        not gray
        and frame.format.name == "yuv420p"
        and frame.color_range != 2
        and frame.width % 2 == 0
        and frame.height % 2 == 0
    ):
        # OpenCV's I420 -> BGR (BT.601, limited range) is about 4x faster than swscale here
        image = cv2.cvtColor(frame.to_ndarray(), cv2.COLOR_YUV2BGR_I420)
    else:
        image = frame.to_ndarray(format="gray" if gray else "bgr24")
    if rotation:
        image = np.ascontiguousarray(np.rot90(image, k=rotation // 90))
    return image


def _fps(stream) -> float:
    rate = stream.average_rate or stream.guessed_rate or stream.base_rate
    return float(rate) if rate else 0.0


def _packet_time(packet, stream) -> float:
    """The presentation time (s) ``_time`` gives the frame a packet with a pts decodes to: that pts in its time base."""
    return float(packet.pts * (packet.time_base or stream.time_base or Fraction(1, 1)))


def _time(frame, stream, index: int, fps: float) -> float:
    """Presentation time in seconds: pts * time_base, or index / fps when the frame has no pts."""
    if frame.pts is not None:
        base = frame.time_base or stream.time_base or Fraction(1, 1)
        return float(frame.pts * base)
    return index / fps if fps else float("nan")


def _progress_bar(total: int, desc: str):
    from tqdm import tqdm

    return tqdm(total=total or None, desc=desc, unit="frame", dynamic_ncols=True)


MIN_KEYFRAME_SAMPLES = 8  # sample_frames takes only keyframes when the video has at least this many (or ``count``)


def sample_frames(path: str | Path, count: int, gray: bool = True) -> dict[int, np.ndarray]:
    """Up to ``count`` frames spread evenly over the whole video, each decoded once by seeking, by 0-based index (as
    ``iter_frames`` numbers them) in order.

    Keyframes when the video has at least ``count`` of them, or at least
    MIN_KEYFRAME_SAMPLES (then every keyframe: a keyframe decodes on its own,
    any other frame costs the frames from its keyframe, up to a whole GOP);
    else frames spread evenly.

    Falls back to the first ``count`` decodable frames when the video cannot
    be indexed or seeked (no timestamps, damaged).
    """
    path = Path(path)
    pts_list, keyframes = _packet_index(path)
    if pts_list:
        n = len(pts_list)
        if len(keyframes) >= min(count, MIN_KEYFRAME_SAMPLES):  # keyframes decode on their own: one decode per sample
            where = {pts: i for i, pts in enumerate(pts_list)}
            picks = np.linspace(0, len(keyframes) - 1, min(count, len(keyframes))).round().astype(int)
            indices = sorted(set(where[keyframes[k]] for k in picks))
        else:
            indices = sorted(set(np.linspace(0, n - 1, min(count, n)).round().astype(int).tolist()))
        if set(pts_list[i] for i in indices) <= set(keyframes):
            try:
                return dict(zip(indices, _read_keyframes(path, [pts_list[i] for i in indices], gray)))
            except TrackInputError:
                pass  # decoded from their keyframes below, as any other frame
        try:
            frames = _read_indexed(path, indices, gray, pts_list, keyframes)
            return {i: frames[i].image for i in indices}
        except TrackInputError:
            pass
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TruncatedVideoWarning)
        for frame in iter_frames(path, gray=gray):
            out[frame.index] = frame.image
            if len(out) >= count:
                break
    return out


def check_init_box(path: Path, info: VideoInfo, init, init_frame) -> tuple[float, float, float, float] | None:
    """The init box [x, y, w, h] (pixels, top-left corner and size) as floats, or None; TrackInputError naming ``path``
    when it or its 0-based frame does not fit the video.
    """
    if isinstance(init_frame, bool) or not isinstance(init_frame, (int, np.integer)) or init_frame < 0:
        raise TrackInputError(f"{path}: init frame must be a 0-based frame index, got {init_frame!r}")
    if info.counted and init_frame >= info.n_frames:
        raise TrackInputError(f"{path}: init frame {init_frame} is past the end of the video ({info.n_frames} frames)")
    if init is None:
        return None
    try:
        x, y, w, h = (float(v) for v in init)
    except (TypeError, ValueError):
        raise TrackInputError(f"{path}: init box must be four numbers x, y, w, h (pixels), got {init!r}") from None
    if not all(math.isfinite(v) for v in (x, y, w, h)) or w <= 0 or h <= 0:
        raise TrackInputError(f"{path}: init box [{x:g}, {y:g}, {w:g}, {h:g}]: width and height must be positive")
    if x < 0 or y < 0 or x + w > info.width or y + h > info.height:
        raise TrackInputError(
            f"{path}: init box [{x:g}, {y:g}, {w:g}, {h:g}] is outside the image ({info.width}x{info.height}); x, y "
            f"is the top-left corner"
        )
    return x, y, w, h
