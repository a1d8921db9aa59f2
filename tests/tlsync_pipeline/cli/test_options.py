"""Every option ``--help`` lists, of every command, run at least once, doing what it says.

CASES is the table: per command, invocations that together use each of its
listed options (test_every_listed_option_is_run checks that against the
commands themselves), each with a check of what the options must do. They
run on a small raw project (two cameras: videos, checkerboard photos, GCPs,
a GPX log; every stage), the paper scene's tracks-only project, a small
Dask cluster in this process, and files made from the raw project.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import re
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import click
import cv2
import pytest
from click.testing import CliRunner, Result

from data_fixtures import make_scene, write_scene
from data_fixtures.raw_project import SMALL, make_raw_project
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.errors import MAX_LINE

RAW = dataclasses.replace(SMALL, lines=SMALL.lines[:2], n_frames=SMALL.n_frames[:2], boards=5)


@dataclass
class World:
    root: Path
    raw: Path  # the raw project's folder (run once)
    tracks: Path  # the tracks-only project's folder
    scheduler: str
    board_video: Path
    init: str  # a box around the target in cam0's video, at init_frame
    init_frame: int
    bag: Path | None

    def fill(self, arg: str) -> str:
        return arg.format(
            root=self.root,
            raw=self.raw,
            tracks=self.tracks,
            sched=self.scheduler,
            boards=self.board_video,
            init=self.init,
            frame=self.init_frame,
            bag=self.bag,
        )


def _cli(*args) -> Result:
    return CliRunner().invoke(main, [str(a) for a in args], prog_name="tlsync", catch_exceptions=False)


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    distributed = pytest.importorskip("distributed")
    root = tmp_path_factory.mktemp("options")
    make_raw_project(root / "raw", RAW)
    assert _cli("run", root / "raw", "-j", "1", "-q").exit_code == 0
    write_scene(make_scene(seed=0), root / "tracks")
    boards = sorted((root / "raw" / "cam0" / "boards").glob("*.png"))
    image = cv2.imread(str(boards[0]))
    writer = cv2.VideoWriter(
        str(root / "boards.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 5, (image.shape[1], image.shape[0])
    )
    for path in boards:
        writer.write(cv2.imread(str(path)))
    writer.release()
    shutil.copytree(
        root / "raw", root / "bad", ignore=shutil.ignore_patterns("work")
    )  # the raw project with a wrong pattern
    toml = root / "bad" / "project.toml"
    toml.write_text(toml.read_text().replace('pattern = "7x5"', 'pattern = "8x6"'))
    with (root / "raw" / "work" / "cameras" / "cam0" / "track.csv").open() as handle:
        row = next(csv.DictReader(handle))
    x, y = float(row["x"]), float(row["y"])
    with distributed.LocalCluster(
        n_workers=1, processes=False, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        yield World(
            root,
            root / "raw",
            root / "tracks",
            cluster.scheduler_address,
            root / "boards.avi",
            f"{x - 10:.0f},{y - 10:.0f},20,20",
            int(row["frame"]),
            _bag(root / "bag"),
        )


def _bag(path: Path) -> Path | None:
    """A tiny ROS 2 bag with poses on /odom (and fixes on /fix), or None without rosbags."""
    try:
        from rosbags.rosbag2 import Writer

        from tests.tlsync_pipeline.ingest.test_rosbag import STORE, T0, _fix, _odom
    except ImportError:
        return None
    with Writer(path, version=9) as writer:
        fix = writer.add_connection("/fix", "sensor_msgs/msg/NavSatFix", typestore=STORE)
        odom = writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=STORE)
        for i in range(20):
            writer.write(fix, T0 * 10**9 + i * 200_000_000, STORE.serialize_cdr(_fix(i), "sensor_msgs/msg/NavSatFix"))
            writer.write(odom, T0 * 10**9 + i * 200_000_000, STORE.serialize_cdr(_odom(i), "nav_msgs/msg/Odometry"))
    return path


@dataclass(frozen=True)
class Case:
    """One invocation: the command, its arguments ({raw}, {tracks}, {root}, ... filled from the World) and the check."""

    command: str
    args: tuple[str, ...]
    check: Callable[[Result, World], None]

    @property
    def id(self) -> str:
        return f"{self.command} " + " ".join(a for a in self.args if a.startswith("-"))


def _ok(result: Result, world: World) -> None:
    assert result.exit_code == 0, result.output


def _ran(task: str) -> Callable[[Result, World], None]:
    def check(result: Result, world: World) -> None:
        assert result.exit_code == 0, result.output
        ran = result.output.split("ran: ", 1)[1].splitlines()[0].split(", ")
        assert task in ran and all(t == task or not t.startswith(task.split("/")[0] + "/") for t in ran), result.output

    return check


def _quiet(result: Result, world: World) -> None:
    assert result.exit_code == 0, result.output
    assert not re.search(r"running|done in|^ran |^warning:", result.output, re.M), result.output


def _run_work(result: Result, world: World) -> None:
    _quiet(result, world)
    assert (world.root / "run-work" / "timeline.json").exists() and not (world.tracks / "work").exists()


def _run_json(result: Result, world: World) -> None:
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    states = {task["id"]: task["state"] for task in document["tasks"]}
    assert document["format"] == "tlsync-run" and states["vote/cam0"] == "ran" and states["vote/cam1"] == "ran"


def _run_truth(result: Result, world: World) -> None:
    assert result.exit_code == 0, result.output
    assert "eps_t (frames)" in result.output and (world.root / "pool" / "timeline.json").exists()


def _run_camera(result: Result, world: World) -> None:
    _ran("track/cam1")(result, world)
    assert "sync" not in result.output.split("ran: ", 1)[1].splitlines()[0]
    assert "sync, export and render use every camera" in result.output


def _run_verbose(result: Result, world: World) -> None:
    """A wrong pattern: one short line naming the board the images show; --verbose adds what was tried, per image."""
    assert result.exit_code == 2, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 2 and all('set pattern = "7x5"' in line and len(line) <= MAX_LINE + 40 for line in errors), (
        result.output
    )
    assert "  tried: the classic detector" in result.output and re.search(
        r"^  board_00\d\.png: ", result.output, re.M
    ), result.output


def _status_typo(result: Result, world: World) -> None:
    assert result.exit_code == 1, result.output
    assert json.loads(result.stdout)["format"] == "tlsync-status"
    assert not (world.root / "wrok").exists()  # a mistyped --work is never made


def _silent(result: Result, world: World) -> None:
    assert result.exit_code == 0 and result.output == "", result.output


def _render_request(result: Result, world: World) -> None:
    assert result.exit_code == 0, result.output
    assert (world.raw / "work" / "render" / "pair_cam0_cam1_frames_40_60_truth.png").stat().st_size > 1000
    assert _cli("status", world.raw, "-q").exit_code == 0


def _demo(result: Result, world: World) -> None:
    assert result.exit_code == 0, result.output
    assert "recovered against true relations" in result.output and "worst eps_t" in result.output


def _files(*names: str) -> Callable[[Result, World], None]:
    def check(result: Result, world: World) -> None:
        assert result.exit_code == 0, result.output
        assert all((world.root / name).stat().st_size > 0 for name in names)

    return check


def _pattern_named(result: Result, world: World) -> None:
    assert (
        result.exit_code == 2
        and result.output.startswith("error: ")
        and result.output.rstrip().endswith("use --pattern 7x5")
    ), result.output


def _bag_case(result: Result, world: World) -> None:
    if world.bag is None:
        pytest.skip("rosbags is not installed")
    assert result.exit_code == 0 and result.output == "", result.output
    assert (world.root / "odom.csv").exists()


SRT = (
    Path(__file__).resolve().parents[1] / "ingest" / "data" / "dji_srt" / "mavic_pro.SRT"
)  # a DJI drone's local wall clock


def _utc_offset(result: Result, world: World) -> None:
    """The drone's local clock read as UTC+10: the trajectory starts at 04:11:51 UTC, 14:11:51 on the drone."""
    assert result.exit_code == 0, result.output
    assert "from 2017-08-05T04:11:51.500000Z" in result.output


PER_CAMERA = ("intrinsics", "calibrate", "track", "clock", "identify", "vote")
PROJECT_WIDE = ("ingest", "sync", "export", "render")

CASES = [
    Case("run", ("{tracks}/project.toml", "--work", "{root}/run-work", "-j", "1", "-q"), _run_work),
    Case("run", ("{tracks}", "--force", "vote", "--json", "--executor", "serial"), _run_json),
    Case(
        "run",
        ("{tracks}", "--truth", "{tracks}/truth.json", "--executor", "process", "--jobs", "2", "--work", "{root}/pool"),
        _run_truth,
    ),
    Case(
        "run", ("{tracks}", "--executor", "dask", "--scheduler", "{sched}", "--work", "{root}/dask", "--quiet"), _quiet
    ),
    Case("run", ("{raw}", "--camera", "cam1", "--force", "track", "-j", "1"), _run_camera),
    Case("run", ("{root}/bad", "-j", "1", "--verbose"), _run_verbose),
    Case("status", ("{tracks}", "--work", "{root}/wrok", "--json"), _status_typo),
    Case("status", ("{raw}/project.toml", "-q", "-v"), _silent),
    *(
        Case(
            s,
            ("{raw}", "--camera", "cam1", "--work", "{raw}/work", "-j", "1", "--executor", "serial", "-v"),
            _ran(f"{s}/cam1"),
        )
        for s in PER_CAMERA
    ),
    *(
        Case(s, ("{raw}", "--work", "{raw}/work", "-j", "1", "--executor", "serial", "-v"), _ran(s))
        for s in PROJECT_WIDE
    ),
    *(
        Case(s, ("{raw}", "--executor", "dask", "--scheduler", "{sched}", "-q"), _quiet)
        for s in PER_CAMERA + PROJECT_WIDE
    ),
    Case(
        "render",
        ("{raw}", "--pair", "cam0,cam1", "--frames", "40,60", "--truth", "{raw}/truth.json", "-j", "1"),
        _render_request,
    ),
    Case("demo", ("{root}/demo", "--quick", "--seed", "1", "--tracking-noise", "0.5", "-j", "1", "-q", "-v"), _demo),
    Case("demo", ("{root}/demo", "--quick", "--seed", "2", "--overwrite", "--jobs", "1"), _demo),
    Case(
        "calibrate-intrinsics",
        (
            "--images",
            "{raw}/cam0/boards/*.png",
            "--pattern",
            "7x5",
            "--square",
            "0.04",
            "--model",
            "rational",
            "-o",
            "{root}/c.json",
            "--report",
            "{root}/c-report.json",
            "-j",
            "1",
            "-q",
            "-v",
        ),
        _files("c.json", "c-report.json"),
    ),
    Case(
        "calibrate-intrinsics",
        (
            "--video",
            "{boards}",
            "--pattern",
            "7x5",
            "--square",
            "0.04",
            "--max-frames",
            "20",
            "--out",
            "{root}/v.json",
            "--jobs",
            "1",
            "--quiet",
        ),
        _files("v.json"),
    ),
    Case(
        "calibrate-intrinsics",
        ("--images", "{raw}/cam0/boards/*.png", "--pattern", "8x6", "--square", "0.04", "-o", "{root}/x.json", "-q"),
        _pattern_named,
    ),
    Case(
        "ingest-log",
        (
            "{raw}/target.gpx",
            "--format",
            "gpx",
            "--origin",
            "46.5197,6.6323,380",
            "--rate",
            "5",
            "--max-gap",
            "2",
            "--max-speed",
            "50",
            "--smoothing",
            "0.5",
            "--altitude-reference",
            "ellipsoid",
            "--altitude-offset",
            "1.5",
            "-o",
            "{root}/t.csv",
            "-v",
        ),
        _files("t.csv", "t.ingest.json"),
    ),
    Case(
        "ingest-log",
        ("{bag}", "--format", "rosbag", "--topic", "/odom", "--out", "{root}/odom.csv", "--quiet"),
        _bag_case,
    ),
    Case("ingest-log", (str(SRT), "--utc-offset", "10", "-o", "{root}/srt.csv"), _utc_offset),
    Case("track-video", ("{raw}/cam0/video.mp4", "-o", "{root}/detections.csv", "-q"), _files("detections.csv")),
    Case(
        "track-video",
        (
            "{raw}/cam0/video.mp4",
            "--tracker",
            "csrt",
            "--init",
            "{init}",
            "--init-frame",
            "{frame}",
            "--out",
            "{root}/csrt.csv",
            "--verbose",
        ),
        _files("csrt.csv"),
    ),
]


@pytest.mark.parametrize("case", CASES, ids=[case.id for case in CASES])
def test_each_option_does_what_it_says(world, case):
    case.check(_cli(case.command, *(world.fill(a) for a in case.args)), world)


def _listed(command: click.Command) -> dict[str, list[str]]:
    """The options ``--help`` lists (by parameter name: all its spellings), without --help."""
    return {
        p.name or "": p.opts + p.secondary_opts
        for p in command.params
        if isinstance(p, click.Option) and not p.hidden and p.name != "help"
    }


def test_every_listed_option_is_run():
    assert isinstance(main, click.Group)
    for name, command in main.commands.items():
        used = {a for case in CASES if case.command == name for a in case.args}
        assert any(case.command == name for case in CASES), f"tlsync {name} is never run"
        missing = [spellings[0] for spellings in _listed(command).values() if not used & set(spellings)]
        assert not missing, f"tlsync {name}: {', '.join(missing)} never run"


@pytest.mark.parametrize("name", sorted(main.commands))
def test_help_lists_every_option(name):
    for flag in ("--help", "-h"):
        result = _cli(name, flag)
        assert result.exit_code == 0 and result.output.startswith(f"Usage: tlsync {name} [OPTIONS]"), result.output
        for spellings in _listed(main.commands[name]).values():
            assert all(s in result.output for s in spellings), (name, spellings)
    assert _cli("--version").output.startswith("tlsync, version ")
    assert "Commands:" in _cli("-h").output


@pytest.mark.parametrize(
    "args, words",
    [
        (("run", "p.toml", "--wrok", "x"), "no such option '--wrok'. Did you mean '--work'?"),
        (("run",), "missing argument 'PROJECT'"),
        (("run", "p.toml", "-j", "0"), "0 is not in the range x>=1"),
        (("status", "p.toml", "--out", "x"), "--out: names the file a standalone command writes"),
        (("sync", "p.toml", "--camera", "cam1"), "--camera: the sync stage uses every camera"),
        (("track-video", "v.mp4"), "missing option '--out' / '-o'"),
        (("frobnicate",), "no such command 'frobnicate'"),
    ],
)
def test_usage_errors_are_one_tlsync_error_line(args, words):
    """Click's own errors ('Usage: ...' and 'Error: ...') come out as tlsync's single 'error:' line, exit code 2."""
    result = _cli(*args)
    assert result.exit_code == 2
    assert len(result.output.splitlines()) == 1 and result.output.startswith("error: ") and words in result.output, (
        result.output
    )
    assert "Usage:" not in result.output and "Error:" not in result.output


def test_a_folder_is_the_project_it_holds(world, tmp_path):
    """run|status|render DIR: the folder's project.toml; a folder without one says so in one line."""
    assert _cli("status", world.tracks, "-q").exit_code in (0, 1)
    empty = _cli("run", tmp_path)
    assert (
        empty.exit_code == 2 and empty.output.startswith("error: ") and "no project.toml in this folder" in empty.output
    )
    (tmp_path / "other.toml").write_text("")
    hint = _cli("render", tmp_path)
    assert hint.exit_code == 2 and "other.toml" in hint.output
