"""Failing like a trusted tool: the exit-code contract, one line per failure, the environment named.

Each test is the paper scene's project (given cameras, tracks, trajectory)
with one thing changed, as a new user would change it.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from click.testing import CliRunner

from tlsync_pipeline.cli.exit_codes import MEANINGS, ExitCode, markdown_table
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.pipeline.lock import WorkLock
from tlsync_pipeline.pipeline.stop import request_stop

README = Path(__file__).resolve().parents[3] / "README.md"


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_the_readme_documents_the_exit_codes_the_code_uses():
    assert markdown_table() in README.read_text(encoding="utf-8")
    assert [int(code) for code in MEANINGS] == [0, 1, 2, 3, 130]
    assert set(MEANINGS) == set(ExitCode)


def test_render_failure_still_prints_the_timeline_and_reports_the_failure_once(project_dir):
    (project_dir / "work").mkdir()
    (project_dir / "work" / "render").write_text("a file where render wants its folder\n")
    result = _cli("run", project_dir / "project.toml", "-j", "1")
    assert result.exit_code == ExitCode.ENVIRONMENT, result.output
    assert re.search(r"^cam1 +ok +2\.0", result.output, re.M), result.output  # the timeline table
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and errors[0].startswith("error: render: ") and "work/render" in errors[0], result.output
    assert "Traceback" not in result.output


def test_each_failure_is_printed_once_on_one_plain_line(project_dir):
    """A camera file that breaks inside the vote stage (not caught before the run): one line, no repr, bounded."""
    camera = project_dir / "cam1" / "camera.json"
    camera.write_text(camera.read_text().replace('"K"', '"K_unused"', 1))
    result = _cli("run", project_dir / "project.toml", "-j", "1")
    assert result.exit_code == ExitCode.BAD_INPUT, result.output
    errors = [line for line in result.output.splitlines() if "error" in line.lower()]
    assert len(errors) == 1, result.output
    assert "camera.json" in errors[0] and len(errors[0]) < 400 and "{" not in errors[0]


@pytest.mark.parametrize("name", [".", "..", ".hidden", "a/b", "..\\\\x", " cam", "cam\\t"])
def test_camera_names_that_would_leave_or_scatter_the_work_folder_are_refused(project_dir, name):
    toml = project_dir / "project.toml"
    toml.write_text(toml.read_text().replace('name = "cam1"', f'name = "{name}"', 1))
    result = _cli("run", toml, "-j", "1")
    assert result.exit_code == ExitCode.BAD_INPUT, result.output
    assert "project.toml" in result.output and "name" in result.output, result.output
    assert not (project_dir / "work").exists()


def test_camera_names_differing_only_in_case_are_refused(project_dir):
    toml = project_dir / "project.toml"
    toml.write_text(toml.read_text().replace('name = "cam1"', 'name = "CAM0"', 1))
    result = _cli("run", toml, "-j", "1")
    assert result.exit_code == ExitCode.BAD_INPUT and "same as 'cam0'" in result.output, result.output


def test_camera_option_on_a_project_wide_stage_is_refused(project_dir):
    toml = project_dir / "project.toml"
    for args in (
        ("sync", toml, "--camera", "cam1"),
        ("export", toml, "--camera", "cam0"),
        ("run", toml, "--force", "sync", "--camera", "cam1"),
    ):
        result = _cli(*args, "-j", "1")
        assert result.exit_code == ExitCode.BAD_INPUT, result.output
        assert re.search(r"^error: .*the (sync|export) stage (is not per camera|uses every camera)", result.output), (
            result.output
        )
        assert len(result.output.splitlines()) == 1, result.output


def test_ffmpeg_script_writes_one_video_per_camera_beside_the_work_folder(project_dir, tmp_path):
    """Run exports/ffmpeg.sh with an ffmpeg that records what it was asked to write."""
    from data_fixtures.video import blank_video

    toml = project_dir / "project.toml"
    text = toml.read_text()
    for name in ("cam0", "cam1"):
        last = max(int(row.split(",")[0]) for row in (project_dir / name / "track.csv").read_text().splitlines()[1:])
        blank_video(project_dir / name / "video.mp4", n_frames=last + 1, image_size=(640, 480))
        text = text.replace(f'name = "{name}"\n', f'name = "{name}"\nvideo = "{name}/video.mp4"\n', 1)
    toml.write_text(text)
    assert _cli("export", toml, "-j", "1", "-q").exit_code == 0
    script = (project_dir / "work" / "exports" / "ffmpeg.sh").read_text()
    assert str(project_dir) not in script  # relative paths: the script works wherever the project is moved
    moved = tmp_path / "moved"
    shutil.copytree(project_dir, moved, ignore=shutil.ignore_patterns("moved", "bin"))
    fake = tmp_path / "bin"
    fake.mkdir()
    # records the file it was asked to write, after checking that its input (the argument after -i) exists
    (fake / "ffmpeg").write_text(
        '#!/bin/sh\nwhile [ "$1" != -i ]; do shift; done\n[ -f "$2" ] || exit 9\nfor last; do :; done\necho '
        '"$PWD/$last" >> "$FFMPEG_LOG"\n'
    )
    (fake / "ffmpeg").chmod(0o755)
    log = tmp_path / "ffmpeg.log"
    env = {**os.environ, "PATH": f"{fake}:{os.environ['PATH']}", "FFMPEG_LOG": str(log)}
    subprocess.run(["sh", str(moved / "work" / "exports" / "ffmpeg.sh")], cwd=tmp_path, env=env, check=True)
    outputs = log.read_text().split()
    assert outputs == [str(moved / "cam0_synced.mp4"), str(moved / "cam1_synced.mp4")]


def test_demo_does_not_overwrite_a_folder_the_user_edited(project_dir, monkeypatch):
    """A folder of the user's (the paper scene's project here), and a demo folder edited after it was made."""
    before = (project_dir / "project.toml").read_text()
    monkeypatch.chdir(project_dir.parent)  # the folder named as a user names it: its path's length is pytest's
    result = _cli("demo", "--quick", project_dir.name)
    assert result.exit_code == ExitCode.BAD_INPUT and "did not write" in result.output, result.output
    assert (project_dir / "project.toml").read_text() == before


# --- The environment: subprocesses in a user namespace, where a read-only or a full file system can be mounted.


def _namespace_available() -> bool:
    if shutil.which("unshare") is None:
        return False
    return subprocess.run(["unshare", "-Urm", "true"], capture_output=True).returncode == 0


needs_namespace = pytest.mark.skipif(
    not _namespace_available(),
    reason="needs unshare -Urm (user and mount namespaces) to mount a small or read-only file system",
)


def _in_namespace(setup: str, *tlsync_args, cwd: Path) -> subprocess.CompletedProcess:
    """Run ``setup`` (mounts) then ``tlsync ARGS`` as root of a new user and mount namespace."""
    command = " ".join(f"'{a}'" for a in tlsync_args)
    script = f"set -e\n{setup}\n'{sys.executable}' -c 'from tlsync_pipeline.cli.main import main; main()' {command}"
    return subprocess.run(["unshare", "-Urm", "sh", "-c", script], capture_output=True, text=True, cwd=cwd)


@pytest.fixture
def shared_project(paper_scene):
    """The paper scene's project in a folder of open permissions (a user namespace maps only this user)."""
    from data_fixtures import write_scene

    folder = Path(tempfile.mkdtemp(prefix="tlsync-env-"))
    write_scene(paper_scene, folder)
    yield folder
    subprocess.run(["umount", "-l", str(folder / "work")], capture_output=True)
    shutil.rmtree(folder, ignore_errors=True)


@needs_namespace
@pytest.mark.parametrize("size", ["24k", "48k"])
def test_a_full_disk_exits_3_naming_every_task_that_failed(shared_project, size):
    work = shared_project / "work"
    work.mkdir()
    result = _in_namespace(
        f"mount -t tmpfs -o size={size} tmpfs '{work}'",
        "run",
        shared_project / "project.toml",
        "-j",
        "1",
        cwd=shared_project,
    )
    output = result.stdout + result.stderr
    assert result.returncode == ExitCode.ENVIRONMENT, output
    assert re.search(r"error: .*\bwork/\S*: the disk is full", output), (
        output
    )  # paths under the current folder are relative
    assert "Traceback" not in output
    failed = {line.split(":")[1].strip() for line in output.splitlines() if line.startswith("error: ")}
    ran = {line.split(":")[0] for line in output.splitlines() if re.match(r"\S+: running\b", line)}
    done = {line.split(":")[0] for line in output.splitlines() if ": done in " in line}
    assert ran - done <= failed and ran - done, output  # every task that started and did not finish is named


@needs_namespace
@pytest.mark.parametrize("command", ["run", "status"])
def test_a_read_only_work_folder_exits_3_in_one_line_naming_it(shared_project, command):
    work = shared_project / "work"
    assert _cli("run", shared_project / "project.toml", "-j", "1", "-q").exit_code == 0
    setup = f"mount --bind '{work}' '{work}'\nmount -o remount,bind,ro '{work}'"
    result = (
        _in_namespace(setup, command, shared_project / "project.toml", "-j", "1", cwd=shared_project)
        if command == "run"
        else _in_namespace(setup, command, shared_project / "project.toml", cwd=shared_project)
    )
    assert result.returncode == ExitCode.ENVIRONMENT, result.stdout + result.stderr
    errors = [line for line in result.stderr.splitlines() if line.strip()]
    assert errors == [
        "error: work: cannot write into the work folder (the file system is read-only); fix it or give another --work "
        "folder"
    ], result.stderr
    assert "Traceback" not in result.stdout + result.stderr


def _shift_trajectory(project_dir, metres: float) -> None:
    path = project_dir / "trajectory.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    x = header.index("x")
    rows = [line.split(",") for line in lines[1:]]
    for row in rows:
        row[x] = repr(float(row[x]) + metres)
    path.write_text("\n".join([lines[0]] + [",".join(r) for r in rows]) + "\n")


def test_no_result_of_an_earlier_sync_survives_a_sync_where_no_camera_synchronizes(project_dir):
    toml = project_dir / "project.toml"
    work = project_dir / "work"
    assert _cli("run", toml, "-j", "1", "-q").exit_code == 0
    assert (work / "exports" / "offsets.csv").exists() and list((work / "render").glob("*.png"))
    _shift_trajectory(project_dir, 300.0)
    result = _cli("run", toml, "-j", "1")
    assert result.exit_code == ExitCode.NOT_SYNCHRONIZED, result.output
    assert re.search(r"^cam0: failed: ", result.output, re.M) and re.search(r"^cam1: failed: ", result.output, re.M), (
        result.output
    )
    assert sorted(p.name for p in (work / "exports").iterdir()) == ["export.manifest.json"]
    assert list((work / "render").glob("*.png")) == []
    assert not [
        line for line in (work / "report.md").read_text().splitlines() if re.match(r"cam[01] ", line)
    ]  # no timeline row


def test_a_camera_that_no_longer_synchronizes_loses_its_pictures_and_exports(project_dir):
    toml = project_dir / "project.toml"
    work = project_dir / "work"
    assert _cli("run", toml, "-j", "1", "-q").exit_code == 0
    assert (work / "render" / "votes_cam1.png").exists()
    rows = "\n".join(f"{f},{2 + f % 3},{2.0}" for f in range(50))
    (project_dir / "cam1" / "track.csv").write_text("frame,x,y\n" + rows + "\n")
    result = _cli("run", toml, "-j", "1", "-q")
    assert result.exit_code == ExitCode.NOT_SYNCHRONIZED, result.output
    pictures = {p.name for p in (work / "render").glob("*.png")}
    assert {"trajectory_cam0.png", "votes_cam0.png"} <= pictures and not [name for name in pictures if "cam1" in name]
    assert "cam1" not in (work / "exports" / "offsets.csv").read_text()
    assert "frame_cam1" not in (work / "exports" / "frame_map.csv").read_text().splitlines()[0]


def test_a_given_track_past_the_end_of_the_camera_video_is_bad_input(project_dir):
    from data_fixtures.video import blank_video

    toml = project_dir / "project.toml"
    blank_video(project_dir / "cam1" / "video.mp4", n_frames=40, image_size=(640, 480))
    toml.write_text(toml.read_text().replace('name = "cam1"\n', 'name = "cam1"\nvideo = "cam1/video.mp4"\n', 1))
    lines = (project_dir / "cam1" / "track.csv").read_text().splitlines()
    line = next(i for i, text in enumerate(lines[1:], start=2) if int(text.split(",")[0]) >= 40)
    result = _cli("run", toml, "-j", "1")
    assert result.exit_code == ExitCode.BAD_INPUT, result.output
    frame = lines[line - 1].split(",")[0]
    assert (
        f"cam1/track.csv:{line}: frame {frame} is past the end of the camera's video" in result.output
        and "which has 40 frames" in result.output
    ), result.output
    assert not (project_dir / "work" / "timeline.json").exists()


def _status(project_dir, *more):
    return _cli("status", project_dir / "project.toml", *more)


def test_status_tells_the_truth_and_its_exit_code_says_whether_everything_is_fresh(project_dir):
    assert _status(project_dir).exit_code == ExitCode.NOT_SYNCHRONIZED  # nothing made yet
    assert _cli("run", project_dir / "project.toml", "-j", "1", "-q").exit_code == 0
    assert _status(project_dir).exit_code == ExitCode.OK
    rows = "\n".join(f"{f},{2 + f % 3},{2.0}" for f in range(50))
    (project_dir / "cam1" / "track.csv").write_text("frame,x,y\n" + rows + "\n")
    assert _status(project_dir).exit_code == ExitCode.NOT_SYNCHRONIZED  # stale
    assert _cli("run", project_dir / "project.toml", "-j", "1", "-q").exit_code == ExitCode.NOT_SYNCHRONIZED
    result = _status(project_dir)
    assert result.exit_code == ExitCode.NOT_SYNCHRONIZED, result.output
    assert re.search(r"^sync +cam1 +failed +camera cam1: ", result.output, re.M), result.output
    document = json.loads(_status(project_dir, "--json").output)
    assert document["format"] == "tlsync-status" and document["exit_code"] == 1 and document["running"] is None
    assert document["cameras"]["cam0"] == {
        "status": "ok",
        "synchronized": True,
        "reason": "",
        "remedy": "",
        "reasons": [],
    }
    cam1 = document["cameras"]["cam1"]
    assert (
        cam1["status"] == "failed"
        and not cam1["synchronized"]
        and cam1["reason"].startswith("camera cam1: ")
        and cam1["remedy"]
    )
    tasks = {t["id"]: t for t in document["tasks"]}
    assert tasks["sync"]["state"] == "fresh" and tasks["sync"]["artefacts"] == ["timeline.json"]
    assert tasks["sync/cam1"]["state"] == "failed"


def test_status_shows_a_failed_stage_with_its_reason_and_a_run_in_progress(project_dir):
    (project_dir / "work" / "exports" / "frame_map.csv").mkdir(parents=True)  # a folder where export writes a file
    assert _cli("run", project_dir / "project.toml", "-j", "1", "-q").exit_code != 0
    with WorkLock(project_dir / "work"):
        result = _status(project_dir)
        document = json.loads(_status(project_dir, "--json").output)
    assert result.exit_code == ExitCode.NOT_SYNCHRONIZED
    assert re.search(r"^export +- +failed +.*exports/frame_map.csv", result.output, re.M), result.output
    assert re.search(r"^render +- +missing +.*waits for export \(failed\)", result.output, re.M), result.output
    assert f"run in progress: pid {os.getpid()} on " in result.output
    assert document["running"]["pid"] == os.getpid()
    assert {t["id"]: t["state"] for t in document["tasks"]}["export"] == "failed"


def test_run_json_is_a_machine_readable_summary(project_dir):
    result = (
        CliRunner(mix_stderr=False).invoke(
            main, ["run", str(project_dir / "project.toml"), "-j", "1", "--json"], catch_exceptions=False
        )
        if "mix_stderr" in CliRunner.__init__.__code__.co_varnames
        else None
    )
    if result is None:  # click >= 8.2 keeps stdout and stderr apart
        result = CliRunner().invoke(
            main, ["run", str(project_dir / "project.toml"), "-j", "1", "--json"], catch_exceptions=False
        )
    document = json.loads(result.stdout)
    assert result.exit_code == 0 and document["format"] == "tlsync-run" and document["exit_code"] == 0
    tasks = {t["id"]: t for t in document["tasks"]}
    assert (
        tasks["sync"]["state"] == "ran"
        and tasks["sync"]["artefacts"] == ["timeline.json"]
        and tasks["sync"]["seconds"] >= 0
    )
    assert {"exports/ffmpeg.sh", "exports/frame_map.csv", "exports/offsets.csv"} <= set(tasks["export"]["artefacts"])
    assert {name: camera["status"] for name, camera in document["cameras"].items()} == {"cam0": "ok", "cam1": "ok"}


@pytest.mark.parametrize("signal_name", ["SIGINT", "SIGTERM"])
def test_a_signal_before_the_command_line_is_imported_exits_130_without_a_traceback(signal_name):
    """The entry point's first lines install a handler: a signal between its import and main() (where the heavy
    imports start) exits 130 at once, not 1 with a KeyboardInterrupt traceback."""
    code = (
        "import os, signal, time\n"
        "import tlsync_pipeline.cli.__main__\n"
        f"os.kill(os.getpid(), signal.{signal_name})\n"
        "time.sleep(10)\n"
    )
    done = _python(code)
    assert done.returncode == 130
    assert done.stderr == "interrupted\n"


def test_a_stop_asked_while_the_command_line_loads_stops_the_command_even_if_an_import_swallowed_it(project_dir):
    """A signal during the command line's imports sets the stop; a KeyboardInterrupt raised inside an extension's
    import can come out as an ImportError that an optional import catches. The command must still stop (130), and
    the next command in the same process must not inherit the stop."""
    runner = CliRunner()
    try:
        request_stop()
    except KeyboardInterrupt:
        pass  # swallowed, as an import may
    stopped = runner.invoke(main, ["status", str(project_dir / "project.toml")])
    assert stopped.exit_code == ExitCode.INTERRUPTED, stopped.output
    assert runner.invoke(main, ["status", str(project_dir / "project.toml")]).exit_code != ExitCode.INTERRUPTED


def test_an_error_left_by_an_interrupted_import_inside_a_command_is_the_stop(project_dir, monkeypatch):
    """A Ctrl-C inside an extension's import comes out of the import as another error (pybind11: "ImportError:
    initialization failed"); the command stops as interrupted (130, the one line), not with a traceback."""
    import tlsync_pipeline.cli.main as cli_main

    def interrupted_import(*args, **kwargs):
        try:
            request_stop()
        except KeyboardInterrupt:
            pass  # turned into the error below by the extension
        raise ImportError("initialization failed")

    monkeypatch.setattr(cli_main, "execute", interrupted_import)
    stopped = CliRunner().invoke(main, ["run", str(project_dir / "project.toml")])
    assert stopped.exit_code == ExitCode.INTERRUPTED, stopped.output
    assert stopped.output.strip().splitlines()[-1].startswith("interrupted: "), stopped.output

    def failed_import(*args, **kwargs):
        raise ImportError("initialization failed")

    monkeypatch.setattr(cli_main, "execute", failed_import)
    failed = CliRunner().invoke(main, ["run", str(project_dir / "project.toml")])
    assert isinstance(failed.exception, ImportError)  # without a stop asked (nor a stop left over), the error itself


def test_an_interrupted_import_of_the_command_line_exits_130_with_the_one_line():
    """The same error out of the command line's own import (before any command): exit 130 and the line, not 1 with
    a traceback, nor -2 (Python ends a normal exit by SIGINT once a KeyboardInterrupt went through an import)."""
    code = (
        "import sys\n"
        "import tlsync_pipeline.cli.__main__ as entry\n"
        "from tlsync_pipeline.pipeline.stop import request_stop\n"
        "class Interrupted:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'tlsync_pipeline.cli.main':\n"
        "            try:\n"
        "                request_stop()\n"
        "            except KeyboardInterrupt:\n"
        "                raise ImportError('initialization failed') from None\n"
        "        return None\n"
        "sys.meta_path.insert(0, Interrupted())\n"
        "sys.argv = ['tlsync', '--help']\n"
        "entry.main()\n"
    )
    done = _python(code)
    assert done.returncode == ExitCode.INTERRUPTED, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith("interrupted: "), done.stderr


def test_a_stop_python_could_not_raise_exits_130_without_a_traceback(tmp_path):
    """Ctrl-C whose handler ran inside a weakref callback (the import system's module locks) cannot raise there:
    Python prints "Exception ignored ... Traceback" and goes on. The stop is remembered: no traceback, and the
    command stops with 130 and the one line."""
    code = (
        "import sys, weakref\n"
        "import tlsync_pipeline.cli.__main__ as entry\n"
        "from tlsync_pipeline.pipeline.stop import request_stop\n"
        "class Lock:\n"
        "    pass\n"
        "held = [Lock()]\n"
        "watch = weakref.ref(held[0], lambda ref: request_stop())\n"
        "class Released:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'tlsync_pipeline.cli.main' and held:\n"
        "            held.clear()\n"
        "        return None\n"
        "sys.meta_path.insert(0, Released())\n"
        f"sys.argv = ['tlsync', 'status', {str(tmp_path / 'project.toml')!r}]\n"
        "entry.main()\n"
    )
    done = _python(code)
    assert done.returncode == ExitCode.INTERRUPTED, done.stderr
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith("interrupted: "), done.stderr


def _python(code: str) -> subprocess.CompletedProcess:
    """``code`` run by a Python process of its own, this tree's packages first on its path."""
    root = Path(__file__).resolve().parents[3]
    env = {**os.environ, "PYTHONPATH": str(root)}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env)
