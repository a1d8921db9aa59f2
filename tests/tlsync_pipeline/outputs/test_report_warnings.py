"""The report shows every warning the stages wrote: one of each stage, made by the stages themselves.

One project, run by the engine: cam0-cam2 synthetic (cam2 at 15 fps, a
rate FCPXML cannot hold: export warns), no videos for them (render notes
it has no strip), and cam3 raw: checkerboard photos with one without a
board (calibrate rejects it) and no pose source (calibrate warns), a
truncated video (track warns), hence an identity pose that cannot be
synchronized (sync). The target comes as a local CSV log with a damaged
line and a hole of 2 s (ingest drops the line and reports the gap).
"""

import html
import re

import numpy as np
import pytest

from data_fixtures import make_scene, write_scene
from data_fixtures.checkerboard import render_checkerboards, write_checkerboards
from data_fixtures.raw_project import PATTERN, SQUARE_M
from data_fixtures.video import render_video
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project

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
    folder = tmp_path_factory.mktemp("warnings")
    scene = make_scene(seed=0, lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)), n_frames=(400, 400, 300))
    project = write_scene(scene, folder)
    _write_log(folder / "log.csv", scene.trajectory, damaged_row=20, hole=(25.0, 27.0))
    boards = render_checkerboards(seed=5, n_full=5, n_cut=0, n_absent=1, image_size=(320, 240), pattern=PATTERN, square=SQUARE_M)
    write_checkerboards(boards, folder / "cam3" / "boards")
    video = render_video(folder / "cam3" / "full.mp4", n_frames=90, seed=2)
    data = video.path.read_bytes()
    (folder / "cam3" / "video.mp4").write_bytes(data[: int(len(data) * 0.6)])
    text = project.read_text().replace('trajectory = "trajectory.csv"', 'log = "log.csv"')
    text += (
        f'\n[[cameras]]\nname = "cam3"\nvideo = "cam3/video.mp4"\nfps = 25.0\n'
        f'[cameras.calibration]\nimages = "cam3/boards/*.png"\npattern = "{PATTERN[0]}x{PATTERN[1]}"\nsquare = {SQUARE_M}\n'
        '[cameras.tracker]\nkind = "blob"\n'
    )
    project.write_text(text)
    graph = build_graph(load_project(project), folder / "work")
    summary = run_graph(graph, targets=["render"])
    assert not summary.failed, summary.failed
    page = (graph.work / "report.html").read_text()
    section = re.search(r'<ul class="warnings">(.*?)</ul>', page, re.S).group(1)
    items = [html.unescape(re.sub(r"<[^>]+>", "", item)) for item in re.findall(r"<li>(.*?)</li>", section, re.S)]
    return items, (graph.work / "report.md").read_text()


@pytest.mark.parametrize(
    "stage, camera, words",
    [
        ("calibrate", "cam3", "rejected: no board"),
        ("calibrate", "cam3", "no gcp or board_pose"),
        ("track", "cam3", "video truncated or corrupt"),
        ("ingest", None, "fix(es) dropped"),
        ("ingest", None, "gap of 2."),
        ("sync", "cam3", "not synchronized"),
        ("export", None, "no timeline.fcpxml: camera cam2 runs at 15 fps"),
        ("render", None, "no strip of matching frames"),
    ],
)
def test_each_stage_warning_is_in_the_report(reported, stage, camera, words):
    items, markdown = reported
    prefix = f"{stage} " + (f"{camera}: " if camera else "")
    matching = [item for item in items if item.startswith(prefix) and words in item]
    assert len(matching) >= 1, (prefix, words, items)
    bullet = f"- **{stage}**" + (f" {camera}" if camera else "") + ": "
    assert any(line.startswith(bullet) and words in line for line in markdown.splitlines()), (bullet, words)


def test_warnings_come_in_pipeline_order(reported):
    items, _ = reported
    stages = [item.split(" ", 1)[0] for item in items]
    order = ["calibrate", "ingest", "scan", "track", "vote", "sync", "export", "render"]
    assert stages == sorted(stages, key=order.index)
    assert np.unique(stages).size >= 6
