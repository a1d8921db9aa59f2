"""Editors' timelines: timeline.otio and timeline.fcpxml read back with opentimelineio, sync.json's convention."""

import csv
import json
from pathlib import Path

import opentimelineio as otio
import pytest

from data_fixtures import make_scene, write_scene
from data_fixtures.video import blank_video
from tlsync_pipeline.outputs.editors import Placement, fcpxml_text, otio_timeline
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A 30 fps and a 25 fps camera (both rates FCPXML knows) synchronized and exported, with video paths."""
    folder = tmp_path_factory.mktemp("editors")
    scene = make_scene(seed=2, lines=((2.0, 4.0), (5.0 / 3.0, 30.0)), n_frames=300)
    project = write_scene(scene, folder)
    text = project.read_text()
    for name, camera in scene.cameras.items():
        blank_video(folder / f"{name}.mp4", scene.n_frames[name], camera.image_size, camera.fps)
        text = text.replace(f'track = "{name}/track.csv"\n', f'track = "{name}/track.csv"\nvideo = "{name}.mp4"\n')
    project.write_text(text)
    graph = build_graph(load_project(project), folder / "work")
    run_graph(graph, targets=["export"])
    with (graph.work / "exports" / "offsets.csv").open() as handle:
        offsets = {row["camera"]: row for row in csv.DictReader(handle)}
    return graph.work, offsets, scene


def _clip_starts(timeline) -> dict[str, tuple[float, float, object]]:
    """Per video track with a clip: (start in seconds on the timeline, the clip's rate, the clip)."""
    out = {}
    for track in timeline.video_tracks():
        clips = [c for c in track.find_clips()]
        if clips:
            start = track.range_of_child(clips[0]).start_time
            out[track.name] = (start.to_seconds(), clips[0].source_range.duration.rate, clips[0])
    return out


def test_otio_round_trip_places_every_clip_at_its_offset(exported):
    work, offsets, scene = exported
    timeline = otio.adapters.read_from_file(str(work / "exports" / "timeline.otio"))
    starts = _clip_starts(timeline)
    assert set(starts) == set(offsets)
    earliest = min(float(r["start_s"]) for r in offsets.values())
    for name, row in offsets.items():
        start, rate, clip = starts[name]
        assert start == pytest.approx(float(row["start_s"]) - earliest, abs=2e-6)  # offsets.csv: 6 decimals
        assert rate == pytest.approx(float(row["fps"]))
        assert clip.source_range.duration.value == scene.n_frames[name]
        assert clip.media_reference.target_url == (work.parent / f"{name}.mp4").resolve().as_uri()
    # one camera starts the edit, and the others keep their true order
    assert min(s for s, _, _ in starts.values()) == pytest.approx(0.0, abs=1e-9)


def test_fcpxml_round_trip_places_every_clip_within_a_frame(exported):
    work, offsets, _ = exported
    timeline = otio.adapters.read_from_file(str(work / "exports" / "timeline.fcpxml"), adapter_name="fcpx_xml")
    starts = {}
    for track in timeline.video_tracks():
        for clip in track.find_clips():
            name = Path(clip.media_reference.target_url).stem
            starts[name] = track.range_of_child(clip).start_time.to_seconds()
    assert set(starts) == set(offsets)
    earliest = min(float(r["start_s"]) for r in offsets.values())
    for name, row in offsets.items():
        assert abs(starts[name] - (float(row["start_s"]) - earliest)) <= 1.0 / float(row["fps"]), name


def test_sync_json_states_its_convention_and_matches_offsets(exported):
    work, offsets, _ = exported
    data = json.loads((work / "exports" / "sync.json").read_text())
    assert "positive means the camera started later than the reference" in data["sign_convention"]
    assert data["reference"] == next(iter(offsets))
    for name, row in offsets.items():
        entry = data["cameras"][name]
        assert entry["start_s"] == pytest.approx(float(row["start_s"]), abs=1e-6)
        if name != data["reference"]:
            low, high = entry["start_s_95"]
            assert low < entry["start_s"] < high
        assert entry["clock"].startswith("CFR")


def test_fcpxml_names_a_rate_it_cannot_write():
    placements = [Placement("a", "a.mp4", 0.0, 30.0, 10, 1 / 3), Placement("b", "b.mp4", 1.0, 15.0, 10, 2 / 3)]
    text, why = fcpxml_text(placements)
    assert text is None and "camera b runs at 15 fps" in why


def test_otio_clip_without_a_video_is_a_missing_reference():
    timeline = otio_timeline(
        [Placement("a", None, -0.5, 30.0, 10, 1 / 3), Placement("b", "b.mp4", 0.25, 25.0, 10, 0.4)]
    )
    starts = _clip_starts(timeline)
    assert starts["a"][0] == 0.0 and starts["b"][0] == pytest.approx(0.75)
    assert isinstance(starts["a"][2].media_reference, otio.schema.MissingReference)
    assert starts["b"][2].media_reference.target_url.startswith("file://")


def test_a_recording_that_breaks_is_one_clip_per_segment_of_known_offset():
    """cam1 froze 25 frames at frame 100 (frames 100-124 of unknown offset): two clips, frames 0-99 and 125-214,
    the second placed 4 s after the first's start (the instant of its first frame), the frozen ones left out."""
    from tlsync_pipeline.outputs.editors import Piece, sync_document

    whole = Placement("cam0", "cam0.mp4", 0.0, 25.0, 300, 12.0)
    broken = Placement("cam1", "cam1.mp4", 2.0, 25.0, 215, 8.6, pieces=(Piece(0, 100, 2.0), Piece(125, 90, 6.0)))
    timeline = otio_timeline([whole, broken])
    track = next(t for t in timeline.video_tracks() if t.name == "cam1")
    clips = list(track.find_clips())
    assert [(c.source_range.start_time.value, c.source_range.duration.value) for c in clips] == [(0, 100), (125, 90)]
    starts = [track.range_of_child(c).start_time.to_seconds() for c in clips]
    assert starts == pytest.approx([2.0, 6.0])
    document = sync_document([whole, broken], "cam0")
    assert [s["first_frame"] for s in document["cameras"]["cam1"]["segments"]] == [0, 125]
    assert document["cameras"]["cam1"]["segments"][1]["timeline_position_s"] == pytest.approx(6.0)
    assert "segments" not in document["cameras"]["cam0"]
