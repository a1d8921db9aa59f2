"""A stage's code for its cache key: the project modules its module imports, without the engine."""

import ast
import importlib.util
import pkgutil

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


def _parsed_imports(source: str) -> list[str]:
    """The import statements that run, from the whole source parsed (nested ones too; not the bodies of ``if`` blocks
    whose test names TYPE_CHECKING, their ``else`` yes), as ``ast.dump`` strings in the order of the source."""
    found = []

    def visit(statements):
        for node in statements:
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                found.append((node.lineno, ast.dump(node)))
            if isinstance(node, ast.If) and any(
                isinstance(n, ast.Name) and n.id == "TYPE_CHECKING" for n in ast.walk(node.test)
            ):
                visit(node.orelse)
                continue
            for field in ("body", "orelse", "finalbody", "handlers", "cases"):
                visit(getattr(node, field, ()))

    visit(ast.parse(source).body)
    return [dump for _, dump in sorted(found)]


def test_the_import_lines_read_are_the_statements_python_parses_in_every_project_module():
    modules = []
    for package in codehash.PACKAGES:
        path = importlib.util.find_spec(package).submodule_search_locations
        modules += [package] + [m.name for m in pkgutil.walk_packages(path, prefix=f"{package}.")]
    assert len(modules) > 100
    for name in modules:
        source = codehash.module_source(name).decode("utf-8")
        assert [ast.dump(n) for n in codehash.import_statements(source)] == _parsed_imports(source), name


def test_import_lines_with_continuations_comments_and_type_checking_blocks():
    source = (
        '"""Docs.\n\nfrom the camera\'s view, import nothing\n"""\n'
        "import os, sys  # two\n"
        "from typing import TYPE_CHECKING\n"
        "from a.b import (  # names\n    c,\n    d,  # the last\n)\n"
        "from . import e \\\n    as f\n"
        "if TYPE_CHECKING:\n    from g import h\n\n    # a comment\n    import i\nelse:\n    import j\n"
        "def k():\n    from ..l import m\n"
    )
    assert [ast.dump(n) for n in codehash.import_statements(source)] == _parsed_imports(source)
    assert [ast.unparse(n) for n in codehash.import_statements(source)] == [
        "import os, sys",
        "from typing import TYPE_CHECKING",
        "from a.b import c, d",
        "from . import e as f",
        "import j",
        "from ..l import m",
    ]
