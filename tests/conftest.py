"""Shared fixtures: synthetic projects written to temporary folders."""

from __future__ import annotations

from pathlib import Path

import pytest

from data_fixtures import make_scene, write_scene


@pytest.fixture(scope="session")
def paper_scene():
    """The paper's default two-camera scene (t_c1 = 2 t_r + 4, t_c2 = 2 t_r + 45), noise-free."""
    return make_scene(seed=0)


@pytest.fixture
def project_dir(tmp_path: Path, paper_scene) -> Path:
    """A complete project folder of the paper scene; returns the folder."""
    write_scene(paper_scene, tmp_path)
    return tmp_path
