"""Killing ``tlsync run`` at random moments leaves nothing behind and nothing that looks fresh but is wrong.

A small raw project (every stage runs, per-camera stages in two worker
processes) is run once uninterrupted: the reference. A copy is then run and
stopped at a random moment, again and again on the same work folder (each
run resumes where the last one stopped, so the stops land in later and later
stages), with SIGKILL, SIGTERM and SIGINT sent to the ``tlsync`` process
only, as a user or a scheduler would. After every stop:

- no process of that run (found by an environment variable every child
  inherits) is left 5 s later;
- SIGTERM and SIGINT exit with 130 and one line, no traceback, no "Aborted!",
  no warning of leaked semaphores, and no temporary (.part) file left;
- every artefact that status calls fresh equals the reference's.

Finally an uninterrupted run writes a timeline.json identical to the reference's.
"""

import hashlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from data_fixtures.raw_project import SMALL, make_raw_project
from tlsync_pipeline.cli.exit_codes import ExitCode
from tlsync_pipeline.pipeline.cache import read_manifest
from tlsync_pipeline.pipeline.engine import manifest_path, status
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options

STOPS = [
    (signal.SIGKILL, 1),
    (signal.SIGTERM, 2),
    (signal.SIGINT, 3),
    (signal.SIGKILL, 4),
    (signal.SIGTERM, 5),
    (signal.SIGINT, 6),
]
MARKER = "TLSYNC_INTERRUPTION_TEST"
# report.md and report.html list when and for how long each stage ran (they differ between any two runs);
# ingest_report.json names the log, and each camera's video.json its video, by absolute path (the reference
# is another copy of the project); other artefacts that name a project file by absolute path (the GCP file in
# calibration_report.json, the videos in the exports) must be the same but for the project's folder.
RUN_RECORDS = {"report.md", "report.html", "target/ingest_report.json"}
NAMES_ITS_SOURCE = "video.json"


def _tlsync_run(project_file: Path, marker: str, log: Path) -> subprocess.Popen:
    env = {**os.environ, MARKER: marker, "PYTHONUNBUFFERED": "1"}
    command = [sys.executable, "-m", "tlsync_pipeline.cli", "run", str(project_file), "-j", "2"]
    with open(log, "w") as handle:
        return subprocess.Popen(command, stdout=handle, stderr=subprocess.STDOUT, env=env)


def _has_finished(log: Path) -> bool:
    """Whether the run's log ends with its last line (the timeline and report written)."""
    lines = log.read_text().strip().splitlines()
    return bool(lines) and lines[-1].startswith("wrote ") and "timeline.json" in lines[-1]


def _processes_with(marker: str) -> list[int]:
    """Live processes (not zombies) whose environment carries ``MARKER=marker``."""
    found = []
    needle = f"{MARKER}={marker}".encode()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if (
                needle in (entry / "environ").read_bytes().split(b"\0")
                and (entry / "stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
            ):
                found.append(int(entry.name))
        except (OSError, IndexError):
            continue
    return found


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _same_but_project_folder(ours: Path, our_project: Path, theirs: Path, their_project: Path) -> bool:
    """Whether two text artefacts are the same once each project's folder is replaced by the same placeholder."""
    try:
        mine, reference = ours.read_text(encoding="utf-8"), theirs.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):  # missing, or not text
        return False
    return mine.replace(str(our_project), "<project>") == reference.replace(str(their_project), "<project>")


def _fresh_artefacts(project_file: Path) -> dict[str, str]:
    """Artefact (relative to the work folder) -> hash on disk, of every task status calls fresh."""
    project = load_project(project_file)
    graph = build_graph(project, project.default_work_dir, Options(progress=False))
    out = {}
    for row in status(graph):
        if row.state == "fresh":
            manifest = read_manifest(manifest_path(graph, graph.tasks[row.id]))
            for relative in manifest.outputs:
                out[relative] = _sha256(graph.work / relative)
    return out


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="finds the run's processes through /proc")
@pytest.mark.slow
def test_runs_stopped_at_random_moments_leave_no_process_and_no_false_fresh_artefact(tmp_path):
    source, _ = make_raw_project(tmp_path / "source", SMALL)

    shutil.copytree(source.parent, tmp_path / "reference")
    reference = tmp_path / "reference" / "project.toml"
    first = _tlsync_run(reference, uuid.uuid4().hex, tmp_path / "reference.log")
    assert first.wait(timeout=600) == 0, (tmp_path / "reference.log").read_text()
    reference_work = reference.parent / "work"
    expected = {p.relative_to(reference_work).as_posix(): _sha256(p) for p in reference_work.rglob("*") if p.is_file()}

    shutil.copytree(source.parent, tmp_path / "stopped")
    project_file = tmp_path / "stopped" / "project.toml"
    stopped_in = []
    for how, seed in STOPS:
        marker = uuid.uuid4().hex
        log = tmp_path / f"stop{seed}.log"
        process = _tlsync_run(project_file, marker, log)
        time.sleep(random.Random(seed).uniform(0.5, 4.0))
        # A run that has printed where its timeline is has done all its work: a signal then only meets its exit.
        finished_first = process.poll() is not None or _has_finished(log)
        process.send_signal(how)
        signalled = time.monotonic()
        code = process.wait(timeout=60)
        output = log.read_text()
        if not finished_first:
            stopped_in.append(output.strip().splitlines()[-1] if output.strip() else "start")
            if how != signal.SIGKILL:
                assert code == ExitCode.INTERRUPTED, output
                assert any(line.startswith("interrupted: ") for line in output.splitlines()), output
                assert "Aborted!" not in output and "Traceback" not in output, output
                assert "leaked semaphore" not in output, output  # the stopped pool's semaphores released
                assert not list((project_file.parent / "work").rglob("*.part")), f"{how.name} left temporary files"
        time.sleep(max(0.0, 5.0 - (time.monotonic() - signalled)))
        assert _processes_with(marker) == [], f"processes of the run left 5 s after {how.name}:\n{output}"

        fresh = _fresh_artefacts(project_file)
        wrong = {
            path
            for path, digest in fresh.items()
            if path not in RUN_RECORDS
            and not path.endswith("/" + NAMES_ITS_SOURCE)
            and expected.get(path) != digest
            and not _same_but_project_folder(
                project_file.parent / "work" / path, project_file.parent, reference_work / path, reference.parent
            )
        }
        for path in (p for p in fresh if p.endswith("/" + NAMES_ITS_SOURCE)):  # the same content but the video's folder
            ours = json.loads((project_file.parent / "work" / path).read_text())
            theirs = json.loads((reference_work / path).read_text())
            assert {**ours, "video": Path(ours["video"]).name} == {**theirs, "video": Path(theirs["video"]).name}, path
        assert not wrong, (
            f"after {how.name}, status calls fresh artefacts that differ from an uninterrupted run's: {sorted(wrong)}"
        )
    assert stopped_in, "no stop landed inside a run"

    final = _tlsync_run(project_file, uuid.uuid4().hex, tmp_path / "final.log")
    assert final.wait(timeout=600) == 0, (tmp_path / "final.log").read_text()
    assert (project_file.parent / "work" / "timeline.json").read_bytes() == (
        reference_work / "timeline.json"
    ).read_bytes()


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "killpg"), reason="sends Ctrl-C to the process group, as a terminal does")
def test_ctrl_c_early_in_calibrate_exits_130_at_once_and_fails_nothing(tmp_path):
    """Ctrl-C as a terminal sends it (SIGINT to the whole process group: tlsync, its worker pool, the checkerboard
    detection's workers) at moments from the interpreter's start to the intrinsics stage: exit 130 within a second,
    the one line, no traceback or "Fatal Python error" from a worker that was starting, nothing marked failed."""
    source, _ = make_raw_project(tmp_path / "source", SMALL)
    for delay in (0.3, 0.8, 1.5, 2.5, 4.0):
        root = tmp_path / f"stop{delay}"
        shutil.copytree(source.parent, root)
        command = [sys.executable, "-m", "tlsync_pipeline.cli", "calibrate", str(root / "project.toml"), "-j", "2"]
        process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
        )
        time.sleep(delay)
        if process.poll() is not None:
            break  # calibrated already: later moments meet no run
        os.killpg(process.pid, signal.SIGINT)
        sent = time.monotonic()
        out, err = process.communicate(timeout=60)
        assert process.returncode == ExitCode.INTERRUPTED and time.monotonic() - sent < 1.0, (delay, err)
        assert "Traceback" not in err and "Fatal Python error" not in err and "unexpected" not in err, (delay, err)
        assert err.strip().splitlines()[-1].startswith("interrupted: "), (delay, err)
        states = status(build_graph(load_project(root / "project.toml"), root / "work"))
        assert not [row.id for row in states if row.state == "failed"], (delay, err)
