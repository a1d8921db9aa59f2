"""Shared fixtures: synthetic projects written to temporary folders."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
from hypothesis import settings

# CI runs Hypothesis derandomized (the same examples every run); elsewhere it explores.
settings.register_profile("ci", derandomize=True, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "default")

from data_fixtures import make_scene, write_scene  # noqa: E402 (after Hypothesis's profile)
from tlsync_pipeline.pipeline.workspace import STRICT_VARIABLE  # noqa: E402
from tlsync_pipeline.sync.kernels.blas import one_blas_thread  # noqa: E402

# A stage that opens a file of the work or project folder it did not declare fails (worker processes inherit this).
os.environ[STRICT_VARIABLE] = "1"

# Tests send SIGINT (Ctrl-C) to the processes they start. A suite started in the background by a non-interactive
# shell (a CI script, nohup ... &) gets SIGINT ignored, and its children would inherit that and never see it.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True, scope="session")
def _one_blas_thread():
    """Tests run numpy and scipy with one BLAS thread, as the engine runs every task: the suite's worker processes
    (pytest-xdist, one per core) then do not each start a thread per core, which spin against each other."""
    with one_blas_thread():
        yield


@pytest.fixture(autouse=True)
def _in_own_folder(tmp_path: Path, monkeypatch) -> None:
    """Each test runs in its own temporary folder (its project's, with project_dir), as a user runs tlsync in the
    project's folder: messages name the files under it relative to it."""
    monkeypatch.chdir(tmp_path)


@pytest.fixture(scope="session")
def paper_scene():
    """The paper's default two-camera scene (t_c1 = 2 t_r + 4, t_c2 = 2 t_r + 45), noise-free."""
    return make_scene(seed=0)


@pytest.fixture
def project_dir(tmp_path: Path, paper_scene) -> Path:
    """A complete project folder of the paper scene; returns the folder."""
    write_scene(paper_scene, tmp_path)
    return tmp_path


@pytest.fixture(scope="session")
def boards():
    """Rendered 9x6 checkerboard photos (800x600, 16 full, 2 cut off, 1 without a board) of a known camera."""
    from data_fixtures.checkerboard import render_checkerboards

    return render_checkerboards(seed=1, n_full=16, n_cut=2, n_absent=1, image_size=(800, 600))


@pytest.fixture(scope="session")
def board_dir(boards, tmp_path_factory) -> Path:
    """The ``boards`` photos as PNG files plus truth.json in a folder."""
    from data_fixtures.checkerboard import write_checkerboards

    return write_checkerboards(boards, tmp_path_factory.mktemp("boards"))
