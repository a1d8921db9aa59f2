"""A stage's code for its cache key: the project modules its module imports, without the engine."""

from tlsync_pipeline.pipeline import codehash
from tlsync_pipeline.pipeline.graph import STAGE_SPECS


def test_each_stage_runs_its_own_modules_and_not_the_engine():
    vote = codehash.closure("tlsync_pipeline.pipeline.stages.vote")
    assert {
        "tlsync_pipeline.pipeline.stages.vote",
        "tlsync_pipeline.sync.vote.votes",
        "trackers.track",
        "calibration.camera",
    } <= set(vote)
    assert "trackers.blob" not in vote and "tlsync_pipeline.outputs.pictures" not in vote
    track = codehash.closure("tlsync_pipeline.pipeline.stages.track")
    assert {"trackers.blob", "trackers.csrt", "trackers.tracking"} <= set(track)  # csrt: imported inside a function
    for spec in STAGE_SPECS.values():
        modules = codehash.closure(spec.run.__module__)
        assert not set(modules) & codehash.ENGINE_MODULES, spec.name
        assert not any(m.startswith("tlsync_pipeline.cli") for m in modules), spec.name
        # Project is imported for annotations only (under TYPE_CHECKING): its edits are not stage code.
        assert "tlsync_pipeline.pipeline.project" not in modules, spec.name


def test_digests_follow_the_sources(monkeypatch):
    before = codehash.code_digests("tlsync_pipeline.pipeline.stages.export")
    assert set(before) == set(codehash.closure("tlsync_pipeline.pipeline.stages.export"))
    original = codehash.module_source
    monkeypatch.setattr(
        codehash,
        "module_source",
        lambda name: original(name) + (b"#" if name == "tlsync_pipeline.outputs.exports" else b""),
    )
    after = codehash.code_digests("tlsync_pipeline.pipeline.stages.export")
    assert [m for m in before if before[m] != after[m]] == ["tlsync_pipeline.outputs.exports"]
