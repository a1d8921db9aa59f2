"""What the cache costs and saves: a full run, a no-op second run, status, one changed camera.

Synthetic project (data_fixtures.scene, given calibrations and tracks), run in
this process (--jobs 1). Prints seconds and ratios to the full run measured in
the same process.

    python bench/pipeline_cache.py [--cameras 8] [--frames 2000]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from data_fixtures.scene import make_scene, write_scene
from tlsync_pipeline.pipeline.engine import run_graph, status
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.spec import Options


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cameras", type=int, default=8)
    parser.add_argument("--frames", type=int, default=2000)
    args = parser.parse_args()
    lines = tuple((2.0, 40.0 * k) for k in range(args.cameras))
    scene = make_scene(0, lines=lines, n_frames=args.frames)
    with tempfile.TemporaryDirectory() as folder:
        project_file = write_scene(scene, folder)

        def graph():
            project = load_project(project_file)
            return build_graph(project, project.default_work_dir, Options(progress=False))

        def timed(fn):
            start = time.perf_counter()
            result = fn()
            return time.perf_counter() - start, result

        full, first = timed(lambda: run_graph(graph()))
        noop, second = timed(lambda: run_graph(graph()))
        stat, _ = timed(lambda: status(graph()))
        camera = Path(folder) / "cam1" / "camera.json"
        data = json.loads(camera.read_text())
        data["t"][0] += 0.01
        camera.write_text(json.dumps(data))
        one, third = timed(lambda: run_graph(graph()))
    print(f"{args.cameras} cameras x {args.frames} frames, {len(scene.trajectory)} target samples")
    print(f"full run        {full:7.2f} s  1.00x   ({len(first.ran)} stages ran)")
    print(f"no-op run       {noop:7.2f} s  {noop / full:.2f}x   ({len(second.ran)} ran, {len(second.fresh)} fresh)")
    print(f"status          {stat:7.2f} s  {stat / full:.2f}x")
    print(f"one camera edit {one:7.2f} s  {one / full:.2f}x   (ran: {', '.join(third.ran)})")


if __name__ == "__main__":
    main()
