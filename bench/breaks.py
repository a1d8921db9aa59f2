"""Recordings with breaks: per break kind and size, the worst pair error against the truth and the verdict.

The small raw demo (data_fixtures.raw_project.SMALL: 30, 25 and 15 fps,
320x240) is made once; for each case cam1's video (25 fps, 190 frames, the
target in frames 23-189) is edited (data_fixtures/breaks.py: its decoded
frames re-encoded with PyAV) and the whole pipeline runs on the copy. For
every pair with cam1, both ways: the worst |mapped - true| frame over the
frames the timeline maps (``Timeline.match``; frames of B), the frames
whose instant the other camera recorded but that are left unmapped
("unmapped"), and the frames mapped to an instant the other camera did not
record ("false"). The first row, "clean", is the unedited demo in the same
run. The ``long_`` cases (``--cases long_clean,long_frozen25_unread,...``)
edit cam1 of a long recording (``LONG_RECORDING``) that the scan stage reads in
windows around the target's stay, with the break outside them.

    python bench/breaks.py [--cases frozen25,dropped25] [--keep DIR]
"""

from __future__ import annotations

import argparse
import functools
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from data_fixtures.breaks import BreakEdit, edit_camera, pair_errors, video_times
from data_fixtures.long_video import render_long_camera_video
from data_fixtures.raw_project import LONG_RECORDING, SMALL, RawProjectSpec, make_raw_project
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options
from tlsync_pipeline.sync.timeline import read_timeline

CAMERA = "cam1"
FPS = 25.0
LONG_FPS = 15.0
LONG_CASES = {
    "long_clean": None,
    "long_frozen25_unread": BreakEdit("frozen", 400, 25),
    "long_restart_parked_unread": BreakEdit("restart", 400, int(300 * LONG_FPS), parked=True),
    "long_restart_light_unread": BreakEdit("restart", 400, int(300 * LONG_FPS), light=0.85),
    "long_frozen25_after": BreakEdit("frozen", 1300, 25),
}
CASES = {
    "clean": None,
    "frozen5": BreakEdit("frozen", 100, 5),
    "frozen25": BreakEdit("frozen", 100, 25),
    "frozen50": BreakEdit("frozen", 100, 50),
    "dropped5": BreakEdit("dropped", 100, 5),
    "dropped5_at140": BreakEdit("dropped", 140, 5),
    "dropped10": BreakEdit("dropped", 100, 10),
    "dropped15": BreakEdit("dropped", 100, 15),
    "dropped25": BreakEdit("dropped", 100, 25),
    "dropped50": BreakEdit("dropped", 100, 50),
    "gap25": BreakEdit("gap", 100, 25),
    "repeat50": BreakEdit("repeat", every=50),
    "restart3min_stamped": BreakEdit("restart", 15, int(180 * FPS), stamped=True),
    "restart3min": BreakEdit("restart", 15, int(180 * FPS)),
    "restart3min_light": BreakEdit("restart", 15, int(180 * FPS), light=0.85),
    "restart3min_parked": BreakEdit("restart", 15, int(180 * FPS), parked=True),
    "gap25_unvisited": BreakEdit("gap", 10, 25),
    "frozen25_at_end": BreakEdit("frozen", 180, 25),
    "ends_at_180": BreakEdit("dropped", 180, 10),  # no break: the recording stops where frozen25_at_end's freezes
}


def run_case(base: Path, folder: Path, edit: BreakEdit | None, spec: RawProjectSpec, fps: float) -> dict:
    """One case: the project (made from ``spec``, cam1 at ``fps``) copied, cam1 edited, the pipeline run; the figures
    of its row."""
    shutil.copytree(base, folder)
    n = {f"cam{k}": count for k, count in enumerate(spec.n_frames)}
    sources = {name: np.arange(count, dtype=np.float64) for name, count in n.items()}
    if edit is not None:
        sources[CAMERA] = edit_camera(folder, CAMERA, edit, fps)
    project = load_project(folder / "project.toml")
    started = time.perf_counter()
    summary = run_graph(build_graph(project, folder / "work", Options(progress=False)))
    seconds = time.perf_counter() - started
    timeline = read_timeline(folder / "work" / "timeline.json")
    lines = {f"cam{k}": line for k, line in enumerate(spec.lines)}
    status = timeline.status(CAMERA)
    worst, unmapped, false = 0.0, 0, 0
    times = video_times(folder, n)
    for other in timeline.names:
        if other == CAMERA or CAMERA not in timeline.cameras:
            continue
        for a, b in ((CAMERA, other), (other, CAMERA)):
            errors, left, wrong = pair_errors(timeline, lines, sources, a, b, times)
            worst = max(worst, float(errors.max()) if len(errors) else 0.0)
            unmapped += left
            false += wrong
    segments = len(timeline.cameras[CAMERA].clock.segments) if CAMERA in timeline.cameras else 0
    codes = ",".join(sorted({r.code for r in status.reasons})) or "-"
    return {
        "status": status.status,
        "codes": codes,
        "exit": 0 if all(timeline.status(name).synchronized for name in n) and not summary.failed else 1,
        "segments": segments,
        "worst": worst if CAMERA in timeline.cameras else None,
        "unmapped": unmapped,
        "false": false,
        "seconds": seconds,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--cases",
        default=",".join(CASES),
        help=f"comma-separated case names (default: all but {', '.join(LONG_CASES)})",
    )
    parser.add_argument("--keep", type=Path, default=None, help="keep the projects in this folder")
    args = parser.parse_args()
    root = args.keep or Path(tempfile.mkdtemp(prefix="tlsync-breaks-"))
    root.mkdir(parents=True, exist_ok=True)
    projects = {
        "base": (SMALL, None, FPS),
        "long": (LONG_RECORDING, functools.partial(render_long_camera_video, radius=5.0, look_alikes=2), LONG_FPS),
    }
    print("| case | cam1 | reasons | segments | exit | worst pair error (frames) | unmapped | false | run (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.cases.split(","):
        folder = root / name
        shutil.rmtree(folder, ignore_errors=True)
        project = "long" if name in LONG_CASES else "base"
        spec, render, fps = projects[project]
        base = root / project
        if not base.exists():
            make_raw_project(base, spec, render=render)
            shutil.rmtree(base / "work", ignore_errors=True)
        row = run_case(base, folder, {**CASES, **LONG_CASES}[name], spec, fps)
        worst = "-" if row["worst"] is None else f"{row['worst']:.3f}"
        print(
            f"| {name} | {row['status']} | {row['codes']} | {row['segments'] or 1} | {row['exit']} | {worst} "
            f"| {row['unmapped']} | {row['false']} | {row['seconds']:.0f} |",
            flush=True,
        )
    if args.keep is None:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
