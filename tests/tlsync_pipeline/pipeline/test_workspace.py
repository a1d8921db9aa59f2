"""The Workspace: portable paths for the cache, and a stage may open only the files it declared.

tests/conftest.py turns the check on for every test, so every stage run by
any test also proves it opens only what its spec declares.
"""

import os

import numpy as np
import pytest

from tlsync_pipeline.pipeline.workspace import (
    STRICT_VARIABLE,
    Artefact,
    UndeclaredFileError,
    Workspace,
)


@pytest.fixture
def files(tmp_path):
    """A vote-like task's view: two declared inputs (a project file, an artefact), one declared artefact."""
    root = tmp_path / "project"
    ws = Workspace(root / "work", root)
    (root / "cam0").mkdir(parents=True)
    (root / "cam0" / "track.csv").write_text("frame,x,y\n")
    (root / "notes.txt").write_text("not declared\n")
    for kind in ("camera", "track"):
        ws.path(kind, "cam0").parent.mkdir(parents=True, exist_ok=True)
        ws.path(kind, "cam0").write_text("{}")
    inputs = {"track": root / "cam0" / "track.csv", "camera": Artefact("camera", "cam0")}
    return ws, ws.files("vote/cam0", "cam0", inputs, [Artefact("votes", "cam0")])


def test_paths_keep_the_documented_layout(tmp_path):
    ws = Workspace(tmp_path / "w", tmp_path)
    assert ws.path("votes", "cam0") == tmp_path / "w" / "cameras" / "cam0" / "votes.npz"
    assert ws.path("frame_map") == tmp_path / "w" / "exports" / "frame_map.csv"
    assert ws.manifest("render", None) == tmp_path / "w" / "render" / "render.manifest.json"
    assert ws.manifest("sync", None) == tmp_path / "w" / "sync.manifest.json"
    assert ws.manifest("intrinsics", "cam2") == tmp_path / "w" / "cameras" / "cam2" / "intrinsics.manifest.json"


def test_portable_paths_do_not_depend_on_where_the_project_is(tmp_path):
    params = {"gcp": None, "files": [None, None], "n": 3}
    seen = []
    for folder, work in ((tmp_path / "a", "work"), (tmp_path / "b" / "deeper", "elsewhere")):
        ws = Workspace(folder / work, folder)
        params.update(gcp=folder / "cam0" / "gcp.csv", files=[folder / "x.png", ws.path("track", "cam0")])
        seen.append((ws.portable(params), ws.portable(Artefact("votes", "cam1"))))
    assert seen[0] == seen[1]
    assert seen[0][0] == {"gcp": "cam0/gcp.csv", "files": ["x.png", "<work>/cameras/cam0/track.csv"], "n": 3}
    assert seen[0][1] == "<work>/cameras/cam1/votes.npz"


def test_a_stage_opens_only_what_it_declared(files):
    ws, view = files
    assert os.environ.get(STRICT_VARIABLE)  # tests/conftest.py turns strict checking on
    with view.running():
        assert view.path("track").read_text() == "frame,x,y\n"
        assert view.path("camera").read_text() == "{}"
        with view.write("votes") as tmp:
            with open(tmp, "wb") as handle:
                np.save(handle, np.zeros(2))
        with pytest.raises(UndeclaredFileError, match="opened .*track.csv for reading"):
            ws.path("track", "cam0").read_text()  # the artefact, not the declared project file
        with pytest.raises(UndeclaredFileError, match="notes.txt"):
            (ws.root / "notes.txt").read_text()
        with pytest.raises(UndeclaredFileError, match="for writing"):
            ws.path("camera", "cam0").write_text("{}")
        with pytest.raises(UndeclaredFileError, match="input 'trajectory' is not declared"):
            view.path("trajectory")
        with pytest.raises(UndeclaredFileError, match="artefact 'timeline' is not declared"):
            view.output("timeline")
    assert ws.path("votes", "cam0").stat().st_size > 0
    assert (ws.root / "notes.txt").read_text() == "not declared\n"  # outside a running stage: no check
