"""Blob and CSRT trackers on rendered videos with known truth."""

import numpy as np
import pytest

from data_fixtures.breaks import BreakEdit, edit_video
from data_fixtures.video import render_video
from trackers.blob import BlobParams
from trackers.breaks import PictureMeter
from trackers.csrt import CsrtParams
from trackers.errors import TrackInputError
from trackers.tracking import track_video


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    """300 frames, 320x240: the target leaves and re-enters three times, passes behind a pole, a distractor crosses."""
    return render_video(tmp_path_factory.mktemp("scene") / "scene.mp4", jitter=0.3)


@pytest.fixture(scope="module")
def tracks(video):
    return {kind: track_video(video.path, kind=kind, progress=False) for kind in ("blob", "csrt")}


def _errors(track, video):
    f = track.frame
    return np.hypot(track.x - video.truth[f, 0], track.y - video.truth[f, 1])


@pytest.mark.parametrize("kind, limit", [("blob", 1.0), ("csrt", 2.0)])
def test_median_position_error(tracks, video, kind, limit):
    track = tracks[kind]
    visible = video.in_view[track.frame]
    assert np.median(_errors(track, video)[visible]) <= limit
    # it follows the target through the video, not just part of it
    assert visible.sum() >= 0.95 * video.in_view.sum()


@pytest.mark.parametrize("kind", ["blob", "csrt"])
def test_nothing_reported_while_the_target_is_out_of_view(tracks, video, kind):
    reported = video.out_of_view[tracks[kind].frame].sum()
    assert video.out_of_view.sum() > 80
    assert reported <= 0.01 * video.out_of_view.sum()


@pytest.mark.parametrize("kind", ["blob", "csrt"])
def test_reacquired_within_ten_frames_of_reentering(tracks, video, kind):
    reported = set(tracks[kind].frame.tolist())
    entries = video.entries()
    assert len(entries) == 3
    for entry in entries:
        assert any(k in reported for k in range(entry, entry + 11)), f"not re-acquired after frame {entry}"


@pytest.mark.parametrize("kind", ["blob", "csrt"])
def test_track_columns(tracks, video, kind):
    track = tracks[kind]
    np.testing.assert_allclose(track.time_s, video.times[track.frame], atol=1e-6)
    assert np.all((track.score > 0) & (track.score <= 1))
    assert np.all(track.w > 0) and np.all(track.h > 0)
    assert np.all(np.diff(track.frame) > 0)


@pytest.mark.parametrize("kind", ["blob", "csrt"])
def test_init_box_while_the_distractor_is_in_view(video, kind):
    """Started at frame 110 (the dark distractor is crossing), it follows the target, not the distractor."""
    f0 = 110
    x, y = video.truth[f0]
    track = track_video(video.path, kind=kind, init=[x - 8, y - 8, 17, 17], init_frame=f0, progress=False)
    assert track.frame[0] >= f0
    visible = video.in_view[track.frame]
    assert np.median(_errors(track, video)[visible]) <= (1.0 if kind == "blob" else 2.0)
    assert visible.sum() >= 0.95 * video.in_view[f0:].sum()
    assert video.out_of_view[track.frame].sum() <= 0.01 * video.out_of_view[f0:].sum()


def test_same_track_twice(video):
    a = track_video(video.path, kind="blob", progress=False)
    b = track_video(video.path, kind="blob", progress=False)
    np.testing.assert_array_equal(a.frame, b.frame)
    np.testing.assert_array_equal(a.x, b.x)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(kind="kcf"), "unknown tracker kind 'kcf'; expected one of: blob, csrt"),
        (dict(init=[300, 100, 40, 40]), r"init box \[300, 100, 40, 40\] is outside the image \(320x240\)"),
        (dict(init=[10, 10, 0, 5]), "width and height must be positive"),
        (dict(init=[10, 10, 5]), "init box must be four numbers"),
        (dict(init_frame=300), r"init frame 300 is past the end of the video \(300 frames\)"),
        (dict(init_frame=-1), "init frame must be a 0-based frame index"),
        (dict(params={"treshold": 3}), r"unknown parameter 'treshold' \(did you mean 'threshold'\?\)"),
        (dict(kind="csrt", params={"patience": 2.5}), "'patience': expected an integer"),
    ],
)
def test_bad_arguments(video, kwargs, message):
    with pytest.raises(TrackInputError, match=message):
        track_video(video.path, progress=False, **kwargs)


def test_parameter_tables():
    assert BlobParams.from_dict({"threshold": 5, "confirm": 4}) == BlobParams(threshold=5.0, confirm=4)
    csrt, blob = CsrtParams.from_dict({"template_size": 100, "gate_px": 30})
    assert csrt.template_size == 100 and blob.gate_px == 30.0
    with pytest.raises(TrackInputError, match="blob detector's parameters"):
        CsrtParams.from_dict({"nope": 1})


def test_blob_with_a_downscaled_background_model(tmp_path):
    """640x360 works on a half-size background model; the centroid is still refined at full resolution."""
    video = render_video(tmp_path / "wide.mp4", n_frames=160, image_size=(640, 360), radius=8.0, seed=4, noise=3.0)
    track = track_video(video.path, kind="blob", progress=False, params={"scale": 2})
    visible = video.in_view[track.frame]
    assert np.median(_errors(track, video)[visible]) <= 1.0
    assert visible.sum() >= 0.95 * video.in_view.sum()
    assert video.out_of_view[track.frame].sum() <= 0.01 * video.out_of_view.sum()


def test_blob_from_a_loose_init_box(video):
    """A box four times the target's size still starts the blob tracker on the target."""
    f0 = 110
    x, y = video.truth[f0]
    track = track_video(video.path, kind="blob", init=[x - 20, y - 20, 40, 40], init_frame=f0, progress=False)
    assert track.frame[0] == f0
    assert np.median(_errors(track, video)[video.in_view[track.frame]]) <= 1.0


def test_positions_are_in_the_upright_picture_of_a_rotated_video(tmp_path):
    """Stored sideways with a display rotation: positions come out in the upright (displayed) picture."""
    video = render_video(tmp_path / "phone.mp4", n_frames=120, rotation=270, seed=2, distractor=False)
    track = track_video(video.path, kind="blob", progress=False)
    visible = video.in_view[track.frame]
    assert visible.sum() >= 0.95 * video.in_view.sum()
    assert np.median(_errors(track, video)[visible]) <= 1.0


def test_median_background_is_the_per_pixel_median_after_the_lighting_gain():
    """Frames of different brightness: the median of the gain-scaled frames (within half a grey level), odd and even
    counts.
    """
    from trackers.blob import median_background

    rng = np.random.default_rng(3)
    scene = rng.uniform(40, 200, (37, 53))
    for count in (15, 8):
        gains = rng.uniform(0.8, 1.2, count)
        frames = [np.clip(scene * g + rng.normal(0, 4, scene.shape), 0, 255).astype(np.uint8) for g in gains]
        means = np.array([f.mean() for f in frames])
        scaled = np.stack([f * (np.median(means) / m) for f, m in zip(frames, means)])
        median, deviation = median_background(frames)
        np.testing.assert_allclose(median, np.median(scaled, axis=0), atol=0.51)
        np.testing.assert_allclose(deviation, np.abs(scaled - np.median(scaled, axis=0)).mean(axis=0), atol=0.6)


@pytest.fixture(scope="module")
def lookalike_video(tmp_path_factory):
    """The target leaves and re-enters the view four times; a grey look-alike of its size wanders inside the view
    from the first frame to the last (and crosses its path)."""
    return render_video(
        tmp_path_factory.mktemp("lookalike") / "lookalike.mp4", n_frames=400, lookalike=True, distractor=False, seed=3
    )


def test_an_init_box_tracks_the_target_and_nothing_while_it_is_out_of_view(lookalike_video, tmp_path):
    """``tlsync track-video VIDEO --tracker blob --init X,Y,W,H`` reports the target, never the look-alike."""
    from click.testing import CliRunner

    from tlsync_pipeline.cli.main import main
    from trackers.track import read_track

    video = lookalike_video
    first = int(np.flatnonzero(video.in_view)[0])
    x, y = video.truth[first]
    box = f"{x - 12:.0f},{y - 12:.0f},24,24"
    out = tmp_path / "track.csv"
    result = CliRunner().invoke(
        main,
        [
            "track-video",
            str(video.path),
            "--tracker",
            "blob",
            "--init",
            box,
            "--init-frame",
            str(first),
            "-o",
            str(out),
            "-q",
        ],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    track = read_track(out)
    assert video.out_of_view.sum() > 100
    assert video.out_of_view[track.frame].sum() == 0  # nothing while the target is out of view
    visible = video.in_view[track.frame]
    assert np.max(_errors(track, video)[visible]) <= 3 * video.radius  # every report is the target
    assert np.median(_errors(track, video)[visible]) <= 1.0
    assert visible.sum() >= 0.95 * video.in_view[first:].sum()  # and it is followed after each return
    reported = set(track.frame.tolist())
    assert all(any(k in reported for k in range(entry, entry + 11)) for entry in video.entries())


def test_csrt_reading_finds_a_frozen_run(video, tmp_path):
    """The CSRT tracker's reading feeds the picture meter too: a stall of 12 frames while the target moves."""
    at = next(k for k in range(40, 300) if video.in_view[k - 3 : k + 3].all())
    edit_video(video.path, tmp_path / "frozen.mp4", BreakEdit("frozen", at, 12), video.fps)
    meter = PictureMeter()
    track_video(tmp_path / "frozen.mp4", kind="csrt", progress=False, meter=meter)
    assert ("frozen", at, 12.0) in [(b.kind, b.frame, b.size) for b in meter.breaks()]


def test_every_mover_from_a_background_read_back_is_as_from_the_frames(lookalike_video, tmp_path):
    """background.npy holds the model exactly: the detections from it are those of a background sampled afresh, and a
    file that is no model is refused by name."""
    from trackers.background import read_background, sample_background, write_background
    from trackers.errors import TrackInputError
    from trackers.tracking import detect_movers, movers_params

    path = lookalike_video.path
    sampled = sample_background(path, movers_params(path, None))
    write_background(sampled, tmp_path / "background.npy")
    read = read_background(tmp_path / "background.npy")
    assert np.array_equal(read.median, sampled.median) and np.array_equal(read.deviation, sampled.deviation)
    windows = [(40, 120), (300, 380)]
    afresh = detect_movers(path, progress=False, windows=windows)
    shared = detect_movers(path, progress=False, windows=windows, background=read)
    assert len(afresh) > 0
    for column in ("frame", "id", "x", "y", "w", "h"):
        assert np.array_equal(getattr(afresh, column), getattr(shared, column)), column
    np.save(tmp_path / "flat.npy", np.zeros((4, 5), np.float32))
    with pytest.raises(TrackInputError, match="flat.npy: not a background model"):
        read_background(tmp_path / "flat.npy")
