"""The command line starts without the heavy libraries: --help, parsing a project, status and ingest-log load
neither OpenCV nor PyAV (they load with the stages that decode or project)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
SRT = ROOT / "tests" / "tlsync_pipeline" / "ingest" / "data" / "dji_srt" / "air2s.srt"
HEAVY = ("cv2", "av", "matplotlib", "numba")


def _modules(code: str, cwd: Path) -> list[str]:
    """Every module loaded after running ``code`` in a fresh interpreter."""
    probe = code + "\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", probe], cwd=cwd, env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def _loaded(code: str, cwd: Path) -> list[str]:
    """The heavy modules loaded after running ``code`` in a fresh interpreter."""
    loaded = set(_modules(code, cwd))
    return [m for m in HEAVY if m in loaded]


def _cli(*args: str) -> str:
    """Run the command line in this interpreter (exit codes ignored), as a ``-c`` program."""
    return (
        "import sys\nfrom tlsync_pipeline.cli.main import main\n"
        f"try:\n    main.main(args={list(args)!r}, prog_name='tlsync', standalone_mode=False)\nexcept SystemExit:\n   "
        f" pass\n"
    )


@pytest.fixture
def project(tmp_path):
    from data_fixtures.scene import make_scene, write_scene

    return write_scene(make_scene(0), tmp_path / "scene")


def test_parsing_a_project_loads_no_heavy_library(project, tmp_path):
    code = (
        f"from tlsync_pipeline.cli.main import main\nfrom tlsync_pipeline.pipeline.project import "
        f"load_project\nload_project({str(project)!r})"
    )
    assert _loaded(code, tmp_path) == []


def test_the_project_file_is_a_leaf(project, tmp_path):
    """Parsing a project imports the configuration's constants and parameter types, not the implementations: no SciPy,
    OpenCV, PyAV, matplotlib; of sync/ only its model (and the smoothing it names as the refined method's preparation);
    of ingest/ its parameters and choices, no reader nor the processing."""
    loaded = _modules(
        f"from tlsync_pipeline.pipeline.project import load_project\nload_project({str(project)!r})", tmp_path
    )
    assert not [m for m in loaded if m.split(".")[0] in ("scipy", *HEAVY)], loaded
    sync = [m for m in loaded if m.startswith("tlsync_pipeline.sync.")]
    assert sync and all(m.startswith(("tlsync_pipeline.sync.model", "tlsync_pipeline.sync.kernels")) for m in sync), (
        sync
    )
    ingest = [m for m in loaded if m.startswith("tlsync_pipeline.ingest.")]
    assert "tlsync_pipeline.ingest.process" not in ingest and not [m for m in ingest if "read" in m], ingest


def test_help_status_and_ingest_log_load_no_heavy_library(project, tmp_path):
    assert _loaded(_cli("--help"), tmp_path) == []
    assert _loaded(_cli("status", str(project)), tmp_path) == []
    out = tmp_path / "srt.csv"
    assert _loaded(_cli("ingest-log", str(SRT), "--out", str(out), "--quiet"), tmp_path) == []
    assert out.exists(), "the command ran"


def test_the_stage_names_are_the_graphs():
    from tlsync_pipeline.ingest.formats import FORMATS
    from tlsync_pipeline.ingest.registry import READERS
    from tlsync_pipeline.pipeline.graph import STAGE_SPECS
    from tlsync_pipeline.pipeline.stage_names import PER_CAMERA, STAGES

    assert STAGES == tuple(STAGE_SPECS)
    assert PER_CAMERA == tuple(name for name, spec in STAGE_SPECS.items() if spec.per_camera)
    assert FORMATS == tuple(reader.name for reader in READERS)
