"""Video reading: indices, presentation times, rotation, seeking, damaged and bad files."""

import warnings
from fractions import Fraction

import av
import numpy as np
import pytest

from data_fixtures.video import render_camera_video, render_video
from trackers import video
from trackers.errors import TrackInputError
from trackers.video import (
    DecodeCount,
    TruncatedVideoWarning,
    iter_frames,
    iter_keyframes,
    iter_windows,
    keyframe_indices,
    merge_windows,
    probe_video,
    read_frames,
    sample_frames,
    seconds_of,
)


@pytest.fixture(scope="module")
def jittered(tmp_path_factory):
    """A variable-frame-rate video: presentation times jittered by up to +-20 % of the interval."""
    return render_video(tmp_path_factory.mktemp("vfr") / "vfr.mp4", n_frames=90, jitter=0.4, seed=3)


def test_indices_and_presentation_times_from_the_container(jittered):
    frames = list(iter_frames(jittered.path, gray=True))
    assert [f.index for f in frames] == list(range(90))
    times = np.array([f.time_s for f in frames])
    assert np.abs(times - jittered.times).max() < 1e-6
    # the jitter is real: a constant-rate assumption would be off by several milliseconds
    assert np.abs(times - np.arange(90) / jittered.fps).max() > 0.004
    assert frames[0].image.shape == (240, 320) and frames[0].image.dtype == np.uint8


def test_bgr_frames_and_probe(jittered):
    first = next(iter_frames(jittered.path))
    assert first.image.shape == (240, 320, 3)
    info = probe_video(jittered.path)
    assert (info.width, info.height, info.n_frames, info.rotation, info.counted) == (320, 240, 90, 0, True)


def test_read_frames_seeks_and_matches_sequential_decoding(jittered):
    wanted = [0, 31, 32, 59, 60, 61, 89]
    sequential = {f.index: f for f in iter_frames(jittered.path) if f.index in wanted}
    sought = read_frames(jittered.path, reversed(wanted))
    assert sorted(sought) == wanted
    for i in wanted:
        assert sought[i].time_s == pytest.approx(sequential[i].time_s, abs=1e-9)
        np.testing.assert_array_equal(sought[i].image, sequential[i].image)


def test_read_frames_skips_the_unreferenced_frames_before_each_wanted_one(jittered, monkeypatch):
    """The video's B-frames that nothing is predicted from are not decoded on the way to a wanted frame (keyframes
    every 30 frames), and the wanted frames come out as sequential decoding gives them."""
    wanted = [28, 58, 59]
    sequential = {f.index: f.image for f in iter_frames(jittered.path) if f.index in wanted}
    decoded = _counting_decodes(monkeypatch)
    sought = read_frames(jittered.path, wanted)
    for i in wanted:
        np.testing.assert_array_equal(sought[i].image, sequential[i])
    run_up = (28 - 0 + 1) + (59 - 30 + 1)  # frames from the keyframe before each wanted frame
    assert 0 < len(decoded) < 0.8 * run_up


def test_read_frames_decodes_nothing_past_the_last_wanted_frame_before_a_seek(jittered, monkeypatch):
    """Before each seek the decoder is drained once the wanted frames' packets are sent: no frame past the last
    wanted one of a keyframe's run-up comes out (the decoder's delay would feed it several more), and the frames are
    those of sequential decoding."""
    wanted = [10, 11, 12, 40, 89]  # 10-12 from keyframe 0, 40 from 30, 89 (the last) from 60
    sequential = {f.index: f.image for f in iter_frames(jittered.path) if f.index in wanted}
    decoded = _counting_decodes(monkeypatch)
    sought = read_frames(jittered.path, wanted)
    for i in wanted:
        np.testing.assert_array_equal(sought[i].image, sequential[i])
    index = {pts: i for i, pts in enumerate(video._packet_index(jittered.path)[0])}
    out = [index[f.pts] for f in decoded]
    assert max(i for i in out if i < 30) == 12 and max(i for i in out if 30 <= i < 60) == 40


def test_read_frames_past_the_end(jittered):
    with pytest.raises(TrackInputError, match=r"frame 90 is past the end of the video \(90 frames\)"):
        read_frames(jittered.path, [3, 90])
    with pytest.raises(TrackInputError, match="negative"):
        read_frames(jittered.path, [-1])


def test_sample_frames_spread_over_the_video(jittered):
    frames = sample_frames(jittered.path, 5)
    assert len(frames) == 5 and all(f.shape == (240, 320) for f in frames.values())
    sequential = {f.index: f.image for f in iter_frames(jittered.path, gray=True)}
    for index, image in frames.items():  # each at its index as iter_frames numbers them
        np.testing.assert_array_equal(image, sequential[index])


def _counting_decodes(monkeypatch, alone: list | None = None):
    """Counts the frames trackers.video decodes (every path goes through _decode or _decode_alone).

    alone: if given, gets the packet of each _decode_alone call (a packet decoded on its own).
    """
    from trackers import video

    decoded = []
    original = video._decode
    original_alone = video._decode_alone

    def counting(container, stream, needed=None, drain_after=None):
        for frame, error in original(container, stream, needed, drain_after):
            decoded.append(frame)
            yield frame, error

    def counting_alone(stream, packet):
        frames = original_alone(stream, packet)
        decoded.extend(frames)
        if alone is not None:
            alone.append(packet)
        return frames

    monkeypatch.setattr(video, "_decode", counting)
    monkeypatch.setattr(video, "_decode_alone", counting_alone)
    return decoded


def test_keyframes_alone_each_decoded_once(jittered, monkeypatch):
    """The keyframes of a VFR video, at their true indices and times, decoded from their own packets only."""
    sequential = {f.index: f for f in iter_frames(jittered.path, gray=True)}
    keys = keyframe_indices(jittered.path)
    assert keys.tolist() == [0, 30, 60]
    packets = []
    decoded = _counting_decodes(monkeypatch, packets)
    count = DecodeCount()
    frames = list(iter_keyframes(jittered.path, count=count))
    assert [f.index for f in frames] == keys.tolist() and count.decoded == 3 and len(decoded) == 3
    assert all(p.is_keyframe for p in packets)
    for frame in frames:
        assert frame.time_s == pytest.approx(sequential[frame.index].time_s, abs=1e-9)
        np.testing.assert_array_equal(frame.image, sequential[frame.index].image)
    assert [f.index for f in iter_keyframes(jittered.path, indices=[60, 0])] == [0, 60]


def test_keyframes_already_decoded_are_not_decoded_again(jittered, monkeypatch):
    """A keyframe handed in (``decoded``) is yielded as given, at the time its decoding gives, without a decode."""
    alone = {f.index: f for f in iter_keyframes(jittered.path)}
    given = {30: sample_frames(jittered.path, 3)[30]}
    decoded = _counting_decodes(monkeypatch)
    count = DecodeCount()
    frames = list(iter_keyframes(jittered.path, count=count, decoded=given))
    assert [f.index for f in frames] == [0, 30, 60] and count.decoded == 2 == len(decoded) and count.yielded == 3
    assert frames[1].image is given[30]
    for frame in frames:
        assert frame.time_s == alone[frame.index].time_s
        np.testing.assert_array_equal(frame.image, alone[frame.index].image)


def test_windows_give_the_frames_of_a_whole_pass(jittered):
    """Frames inside windows: the indices, times and pixels of iter_frames; decoding starts at
    each window's keyframe.
    """
    sequential = {f.index: f for f in iter_frames(jittered.path, gray=True)}
    count = DecodeCount()
    frames = list(iter_windows(jittered.path, [(40, 45), (33, 41), (70, 200), (0, 3)], gray=True, count=count))
    expected = [*range(0, 3), *range(33, 45), *range(70, 90)]
    assert [f.index for f in frames] == expected
    for frame in frames:
        assert frame.time_s == pytest.approx(sequential[frame.index].time_s, abs=1e-9)
        np.testing.assert_array_equal(frame.image, sequential[frame.index].image)
    # from keyframe 0 to frame 2, from keyframe 30 to 44, from keyframe 60 to the end
    assert (count.yielded, count.decoded) == (len(expected), 3 + 15 + 30)


def test_merge_windows():
    assert merge_windows([(10, 20), (0, 5), (18, 30), (33, 40), (50, 50)], gap=3) == [(0, 5), (10, 40)]


@pytest.mark.parametrize("rotation", [0, 90, 180, 270])
def test_probe_reads_the_rotation_from_the_container_without_decoding(tmp_path, monkeypatch, rotation):
    rotated = render_video(tmp_path / "rotated.mp4", n_frames=4, seed=5, noise=0.0, rotation=rotation)
    decoded = _counting_decodes(monkeypatch)
    info = probe_video(rotated.path)
    assert decoded == []
    assert (info.width, info.height, info.rotation) == (320, 240, rotation)
    assert next(iter_frames(rotated.path)).image.shape == (240, 320, 3)  # what decoding gives


def test_probe_of_a_container_without_a_track_header_decodes_the_first_frame(tmp_path, monkeypatch):
    """Matroska keeps no MP4 track header: the rotation comes from the first decoded frame."""
    path = tmp_path / "clip.mkv"
    with av.open(str(path), "w") as container:
        stream = container.add_stream("mpeg4", rate=25)
        stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
        for i in range(3):
            frame = av.VideoFrame.from_ndarray(np.full((48, 64, 3), 40 * i, np.uint8), format="bgr24")
            container.mux(stream.encode(frame))
        container.mux(stream.encode())
    decoded = _counting_decodes(monkeypatch)
    info = probe_video(path)
    assert (info.width, info.height, info.rotation) == (64, 48, 0) and len(decoded) == 1


def test_background_samples_are_keyframes_each_decoded_once(tmp_path, monkeypatch):
    """A video with fewer keyframes than samples asked for, but enough: every keyframe, one decode each."""
    clip = render_video(tmp_path / "gop.mp4", n_frames=100, seed=2, gop=10)
    packets = []
    decoded = _counting_decodes(monkeypatch, packets)
    frames = sample_frames(clip.path, 15)
    assert len(frames) == 10 and len(decoded) == 10
    assert all(f.key_frame for f in decoded)
    assert len(packets) == 10 and all(p.is_keyframe for p in packets)  # the decoder got the keyframes' packets only
    keyframes = read_frames(clip.path, range(0, 100, 10), gray=True)
    assert list(frames) == list(range(0, 100, 10))
    for index, frame in frames.items():
        np.testing.assert_array_equal(frame, keyframes[index].image)


def test_rotation_metadata_is_honoured(tmp_path):
    upright = render_video(tmp_path / "upright.mp4", n_frames=12, seed=5, noise=0.0)
    rotated = render_video(tmp_path / "rotated.mp4", n_frames=12, seed=5, noise=0.0, rotation=90)
    info = probe_video(rotated.path)
    assert (info.width, info.height, info.rotation) == (320, 240, 90)
    a = next(iter_frames(upright.path, gray=True)).image.astype(float)
    b = next(iter_frames(rotated.path, gray=True)).image.astype(float)
    assert b.shape == a.shape
    assert np.abs(a - b).mean() < 3.0  # same picture, up to compression
    assert np.abs(a - np.flipud(np.fliplr(b))).mean() > 10.0  # a wrong rotation would not be
    assert read_frames(rotated.path, [5])[5].image.shape == (240, 320, 3)


def test_truncated_file_is_read_up_to_its_last_decodable_frame(tmp_path, jittered):
    data = jittered.path.read_bytes()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    with pytest.warns(
        TruncatedVideoWarning, match=r"cut.mp4: video truncated or corrupt .*read up to frame (\d+)"
    ) as record:
        frames = list(iter_frames(cut))
    assert 10 < len(frames) < 90
    assert f"read up to frame {frames[-1].index} " in str(record[0].message)
    assert [f.index for f in frames] == list(range(len(frames)))


def test_complete_file_reads_without_warning(jittered):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert sum(1 for _ in iter_frames(jittered.path)) == 90


def _empty_video(path):
    container = av.open(str(path), "w")
    stream = container.add_stream("libx264", rate=25)
    stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
    container.start_encoding()
    container.close()
    return path


def _audio_only(path):
    container = av.open(str(path), "w")
    container.add_stream("pcm_s16le", rate=8000)
    container.start_encoding()
    container.close()
    return path


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda d: d / "missing.mp4", "file not found"),
        (lambda d: d, "is a folder"),
        (lambda d: (d / "notes.mp4").write_text("not a video\n" * 50) and d / "notes.mp4", "not a readable video file"),
        (lambda d: _audio_only(d / "sound.wav"), "has no video stream"),
        (lambda d: _empty_video(d / "empty.mkv"), "ends before any video frame"),
    ],
)
def test_bad_files_have_clear_errors(tmp_path, make, message):
    path = make(tmp_path)
    with pytest.raises(TrackInputError, match=message) as info:
        list(iter_frames(path))
    assert str(path) in str(info.value)


def test_video_without_any_decodable_frame(tmp_path, jittered):
    data = jittered.path.read_bytes()
    header_only = tmp_path / "header_only.mp4"
    header_only.write_bytes(data[: data.index(b"mdat") + 4])
    with pytest.raises(TrackInputError, match="header_only.mp4: the video has no decodable frame"):
        list(iter_frames(header_only))


def test_render_camera_video_draws_given_positions(tmp_path, paper_scene):
    camera = paper_scene.true_cameras["cam0"]
    positions = [None] * 5 + [(100.0 + 3 * k, 200.0) for k in range(15)]
    rendered = render_camera_video(camera, positions, fps=camera.fps, path=tmp_path / "cam0.mp4")
    info = probe_video(rendered.path)
    assert (info.width, info.height) == tuple(camera.image_size) and info.n_frames == 20
    assert info.fps == pytest.approx(camera.fps, rel=1e-3)
    assert rendered.out_of_view[:5].all() and rendered.in_view[5:].all()
    frame = read_frames(rendered.path, [10], gray=True)[10].image
    assert frame[200, 115] > 200 and frame[200, 60] < 200  # the bright disc is where it was asked to be


def test_corrupt_middle_stops_with_a_warning_naming_the_last_good_frame(tmp_path, jittered):
    data = bytearray(jittered.path.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 3000] = np.random.default_rng(0).integers(0, 256, 3000, dtype=np.uint8).tobytes()
    damaged = tmp_path / "damaged.mp4"
    damaged.write_bytes(bytes(data))
    with pytest.warns(TruncatedVideoWarning, match="damaged.mp4: video truncated or corrupt") as record:
        frames = list(iter_frames(damaged))
    assert 0 < len(frames) < 90
    assert f"read up to frame {frames[-1].index} " in str(record[0].message)


def test_bgr_frames_agree_with_ffmpegs_conversion(jittered):
    ours = read_frames(jittered.path, [10])[10].image.astype(int)
    with av.open(str(jittered.path)) as container:
        for k, frame in enumerate(container.decode(video=0)):
            if k == 10:
                reference = frame.to_ndarray(format="bgr24").astype(int)
                break
    assert np.abs(ours - reference).max() <= 3


def test_grey_frames_are_read_only_views_that_stay_intact(tmp_path):
    """Grey frames are the decoder's luma buffer when its rows are unpadded (not a copy): read-only, and unchanged
    by decoding further frames."""
    clip = render_video(tmp_path / "wide.mp4", n_frames=60, seed=4, image_size=(640, 240))
    kept = [f.image for f in iter_frames(clip.path, gray=True)][::10]
    assert not kept[0].flags.writeable and kept[0].shape == (240, 640)
    with pytest.raises(ValueError):
        kept[0][0, 0] = 0
    again = read_frames(clip.path, range(0, 60, 10), gray=True)
    for image, index in zip(kept, range(0, 60, 10)):
        np.testing.assert_array_equal(image, again[index].image)


def test_seconds_of_timestamps_are_the_exact_products_rounded():
    """Each timestamp times the time base as float(pts * base) gives it, whether one division of exact floats does it
    or the products reach 2**53."""
    rng = np.random.default_rng(6)
    pts = np.concatenate([np.arange(-3, 5000), rng.integers(0, 10**12, 5000)]).astype(np.int64)
    for base in (Fraction(1, 15360), Fraction(1001, 30000), Fraction(1, 90000), Fraction(3, 7), Fraction(10**6, 3)):
        expected = np.array([float(int(p) * base) for p in pts])
        assert np.array_equal(seconds_of(pts, base), expected)
    assert seconds_of(np.zeros(0, np.int64), Fraction(1, 25)).shape == (0,)
