"""One list of warnings per run, the same on the terminal, in report.html, report.md and timeline.json.

One project, run by the engine: cam0-cam2 synthetic (cam2 at 15 fps, a
rate FCPXML cannot hold: export warns), no videos for them (render notes
it has no strip), and cam3 raw: checkerboard photos with one without a
board (intrinsics rejects it) and surveyed GCPs with one wrong point
(calibrate leaves it out), a truncated video (track warns) of no target,
hence a camera that cannot be synchronized (sync). The target comes as a local CSV log with a damaged
line and a hole of 2 s (ingest drops the line and reports the gap).
"""

import html
import json
import re

import pytest
from click.testing import CliRunner

from data_fixtures import make_scene, write_scene
from data_fixtures.checkerboard import render_checkerboards, write_checkerboards
from data_fixtures.gcp import looking_at, make_gcps, write_gcp_csv
from data_fixtures.raw_project import PATTERN, SQUARE_M
from data_fixtures.video import render_video
from tlsync_pipeline.cli.main import main

pytestmark = pytest.mark.filterwarnings("ignore::trackers.video.TruncatedVideoWarning")  # cam3's video, on purpose


def _write_log(path, trajectory, damaged_row: int, hole: tuple[float, float]) -> None:
    """``t,x,y,z`` rows of the trajectory (t = sample / rate), one row cut short, none inside ``hole`` (s)."""
    lines = ["t,x,y,z"]
    for k, (s, (x, y, z)) in enumerate(zip(trajectory.sample, trajectory.xyz)):
        t = s / trajectory.rate
        if hole[0] < t < hole[1]:
            continue
        row = f"{t:.6f},{x:.6f},{y:.6f},{z:.6f}"
        lines.append(row.rsplit(",", 1)[0] if k == damaged_row else row)
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def reported(tmp_path_factory):
    """The project run by ``tlsync run``: the terminal's output, the report's warnings (HTML items), report.md,
    timeline.json, the work folder.
    """
    folder = tmp_path_factory.mktemp("warnings")
    scene = make_scene(seed=0, lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)), n_frames=(400, 400, 300))
    project = write_scene(scene, folder)
    _write_log(folder / "log.csv", scene.trajectory, damaged_row=20, hole=(25.0, 27.0))
    boards = render_checkerboards(
        seed=5, n_full=5, n_cut=0, n_absent=1, image_size=(320, 240), pattern=PATTERN, square=SQUARE_M
    )
    write_checkerboards(boards, folder / "cam3" / "boards")
    R, t = looking_at((3.0, -15.0, 6.0), (0.0, 5.0, 0.0))
    uv, xyz, _ = make_gcps(boards.K, boards.dist, R, t, boards.image_size, n=8, seed=1)
    uv[3] += [40.0, -30.0]  # a point clicked in the wrong place
    write_gcp_csv(folder / "cam3" / "gcp.csv", uv, xyz)
    video = render_video(folder / "cam3" / "full.mp4", n_frames=90, seed=2)
    data = video.path.read_bytes()
    (folder / "cam3" / "video.mp4").write_bytes(data[: int(len(data) * 0.6)])
    text = project.read_text().replace('trajectory = "trajectory.csv"', 'log = "log.csv"')
    text += (
        f'\n[[cameras]]\nname = "cam3"\nvideo = "cam3/video.mp4"\nfps = 25.0\n'
        f'[cameras.calibration]\nimages = "cam3/boards/*.png"\npattern = "{PATTERN[0]}x{PATTERN[1]}"\nsquare = '
        f'{SQUARE_M}\ngcp = "cam3/gcp.csv"\ngcp_sigma_m = 0\n'
        '[cameras.tracker]\nkind = "blob"\n'
    )
    project.write_text(text)
    result = CliRunner().invoke(main, ["run", str(project), "-j", "1"], catch_exceptions=False)
    assert result.exit_code == 1, result.output  # cam3 cannot be synchronized (its video has no target)
    work = folder / "work"
    page = (work / "report.html").read_text()
    section = re.search(r'<ul class="warnings">(.*?)</ul>', page, re.S).group(1)
    items = [html.unescape(re.sub(r"<[^>]+>", "", item)) for item in re.findall(r"<li>(.*?)</li>", section, re.S)]
    return (
        result.output,
        items,
        (work / "report.md").read_text(),
        json.loads((work / "timeline.json").read_text()),
        project,
    )


def _terminal_warnings(output: str) -> list[tuple[str, str | None, str]]:
    found = []
    for line in output.splitlines():
        if line.startswith("warning: "):
            task, text = line[len("warning: ") :].split(": ", 1)
            stage, _, camera = task.partition("/")
            found.append((stage, camera or None, text))
    return found


def test_one_list_of_warnings_on_the_terminal_in_the_report_and_in_timeline_json(reported):
    output, items, markdown, timeline, _ = reported
    listed = [(w["stage"], w["camera"], w["text"]) for w in timeline["warnings"]]
    assert _terminal_warnings(output) == listed
    assert items == [f"{stage} " + (f"{camera}: " if camera else "") + text for stage, camera, text in listed]
    bullets = [
        line for line in markdown.split("## Warnings", 1)[1].split("\n## ", 1)[0].splitlines() if line.startswith("- ")
    ]
    assert bullets == [
        f"- **{stage}**" + (f" {camera}" if camera else "") + f": {text}" for stage, camera, text in listed
    ]
    assert len(set(listed)) == len(listed)  # each once
    assert f"{len(listed)} warnings; see " in output


@pytest.mark.parametrize(
    "stage, camera, words",
    [
        ("intrinsics", "cam3", "rejected: no board"),  # the stage that detects the boards, not calibrate
        ("calibrate", "cam3", "left out as an outlier"),
        ("track", "cam3", "video truncated or corrupt"),
    ],
)
def test_each_warning_is_under_the_stage_that_raised_it(reported, stage, camera, words):
    listed = reported[3]["warnings"]
    assert [w for w in listed if w["stage"] == stage and w["camera"] == camera and words in w["text"]], listed


def test_what_is_not_a_warning_has_its_own_place(reported):
    """The log's dropped lines and gaps are in the ingest summary, an editor timeline export could not write is in
    the exports section; cameras without videos (cam0-cam2) have no strip, and nothing says so."""
    output, items, markdown, timeline, _ = reported
    target_log = markdown.split("## Target log", 1)[1].split("\n## ", 1)[0]
    assert "expected 4 fields (line 22)" in target_log and re.search(
        r"\n +2\.\d+ s after line \d+: not bridged", target_log
    ), target_log
    exports = markdown.split("## Exports", 1)[1].split("\n## ", 1)[0]
    assert "no timeline.fcpxml: camera cam2 runs at 15 fps" in exports
    assert "no timeline.fcpxml" in output and not any("fcpxml" in w["text"] for w in timeline["warnings"])
    assert "strip" not in " ".join(items) + markdown.split("## Pictures", 1)[1].lower().replace("strip_", "")


def test_a_cached_run_counts_the_warnings_it_does_not_repeat(reported):
    output, _, _, timeline, project = reported
    again = CliRunner().invoke(main, ["run", str(project), "-j", "1"], catch_exceptions=False)
    assert "ran 0," in again.output and not _terminal_warnings(again.output)
    assert f"{len(timeline['warnings'])} warnings; see " in again.output
    quiet = CliRunner().invoke(main, ["run", str(project), "-j", "1", "-q"], catch_exceptions=False)
    assert not _terminal_warnings(quiet.output) and "warnings; see" not in quiet.output
