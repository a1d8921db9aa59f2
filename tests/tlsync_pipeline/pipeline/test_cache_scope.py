"""What each stage's cache key covers: the packages its code may import (docs/architecture.md, "Cache scope").

A stage's code is its module's import closure (pipeline/codehash.py); these
tests pin it, so that an edit re-runs only the stages that run the edited
module: the sync fit never re-runs scan, track, calibrate, identify or vote,
and the track stage imports nothing of ``sync``.
"""

from __future__ import annotations

import pkgutil

import pytest

import tlsync_pipeline.pipeline.stages as stages
from tlsync_pipeline.pipeline import codehash
from tlsync_pipeline.pipeline.graph import STAGE_SPECS

SYNC = "tlsync_pipeline.sync."
EVERY = frozenset({"model", "kernels", "vote", "identify", "pose", "solve", "timeline", "clock_prior"})
# Stage -> the parts of sync/ (a package, or a module such as "vote.votes") its code may import.
MAY_IMPORT = {
    "intrinsics": frozenset(),
    "calibrate": frozenset({"model", "kernels", "vote", "identify", "pose"}),
    "track": frozenset(),
    "scan": frozenset({"model", "kernels", "vote", "identify", "pose"}),
    "ingest": frozenset(),
    "clock": frozenset(),
    "identify": frozenset({"model", "kernels", "vote", "identify"}),
    "vote": frozenset({"model", "kernels", "vote"}),
    "sync": EVERY,
    "export": frozenset({"model", "timeline", "clock_prior"}),
    "render": EVERY,
}
BEFORE_SYNC = ("intrinsics", "calibrate", "track", "scan", "ingest", "clock", "identify", "vote")


def _closure(stage: str) -> tuple[str, ...]:
    return codehash.closure(STAGE_SPECS[stage].run.__module__)


def _sync_parts(modules) -> set[str]:
    return {m.removeprefix(SYNC) for m in modules if m.startswith(SYNC)}


def _allowed(part: str, allowed: frozenset[str]) -> bool:
    return any(part == a or part.startswith(a + ".") for a in allowed)


def test_every_stage_is_pinned():
    assert set(MAY_IMPORT) == set(STAGE_SPECS)


@pytest.mark.parametrize("stage", sorted(MAY_IMPORT))
def test_each_stage_imports_only_its_parts_of_sync(stage):
    wrong = sorted(p for p in _sync_parts(_closure(stage)) if not _allowed(p, MAY_IMPORT[stage]))
    assert not wrong, f"the {stage} stage's code imports {wrong}: widen MAY_IMPORT only if the stage runs them"


def test_the_track_stage_imports_no_sync_and_no_outputs():
    assert not [m for m in _closure("track") if m.startswith(("tlsync_pipeline.sync", "tlsync_pipeline.outputs"))]


def test_the_log_bias_fit_is_code_of_sync_and_what_follows_only():
    from tlsync_pipeline.sync.solve.log_bias import fit_log_bias

    module = fit_log_bias.__module__
    assert [s for s in BEFORE_SYNC if module in _closure(s)] == []
    assert module in _closure("sync")


def test_the_timeline_writer_is_not_code_of_the_stages_before_sync():
    from tlsync_pipeline.sync.timeline import write_timeline

    module = write_timeline.__module__
    assert [s for s in BEFORE_SYNC if module in _closure(s)] == []
    assert {"sync", "export", "render"} <= {s for s in STAGE_SPECS if module in _closure(s)}


def test_preparing_the_trajectory_imports_no_fit():
    """The vote, identify, scan and calibrate stages prepare the trajectory (sync/model/methods.py) without the methods'
    fits.
    """
    for stage in ("vote", "identify", "scan", "calibrate"):
        assert not _sync_parts(_closure(stage)) & {
            "solve.registry",
            "solve.refined",
            "solve.paper",
            "solve.synchronize",
        }, stage


def test_the_model_and_the_kernels_import_no_other_part_of_sync():
    for package in ("model", "kernels"):
        path = [p for p in __import__(f"{SYNC}{package}", fromlist=["_"]).__path__]
        for info in pkgutil.iter_modules(path):
            module = f"{SYNC}{package}.{info.name}"
            wrong = sorted(
                p for p in _sync_parts(codehash.closure(module)) if not _allowed(p, frozenset({"model", "kernels"}))
            )
            assert not wrong, f"{module} imports {wrong}"


def test_the_stage_modules_are_all_known():
    """Every module of pipeline/stages is a stage's or one the stages share (a new helper module is placed here on
    purpose).
    """
    shared = {"cameras", "camera_plan"}
    found = {info.name for info in pkgutil.iter_modules(stages.__path__)}
    assert found == set(MAY_IMPORT) | shared
