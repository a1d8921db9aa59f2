"""``tlsync demo``: a generated project run end to end, recovered against true relations.

By default the project is raw, as users bring it (three cameras at 30, 25 and
15 fps with H.264 videos, checkerboard photos, geodetic ground control
points, a GPX log of the target), so every stage runs: calibrate, track,
ingest, vote, sync, export, render. ``--quick`` uses the synthetic scene with
ready-made calibrations and tracks instead (seconds, no video).
"""

from __future__ import annotations

import time
from pathlib import Path

import click

from tlsync_pipeline.cli.pipeline import execute, finish
from tlsync_pipeline.outputs.summary import format_table, format_truth_comparison
from tlsync_pipeline.sync.timeline import read_timeline


@click.command("demo")
@click.argument("directory", required=False, type=click.Path(file_okay=False, path_type=Path), default=Path("tlsync-demo"))
@click.option("--quick", is_flag=True, help="Synthetic calibrations and tracks instead of raw videos, photos and logs (seconds).")
@click.option("--seed", default=0, show_default=True, help="Scene seed.")
@click.option("--tracking-noise", default=1.0, show_default=True, help="With --quick: tracking noise S_t (pixels).")
@click.option("--jobs", "-j", type=click.IntRange(min=1), help="Worker processes (default: one per core).")
@click.option("--quiet", "-q", is_flag=True, help="No progress messages.")
def demo(directory: Path, quick: bool, seed: int, tracking_noise: float, jobs: int | None, quiet: bool) -> None:
    """Generate a three-camera project in DIRECTORY, run the pipeline on it, compare with the truth."""
    start = time.perf_counter()
    if quick:
        from data_fixtures.scene import make_scene, write_scene

        scene = make_scene(seed, lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)), n_frames=(512, 512, 300), tracking_noise_px=tracking_noise)
        project_file = write_scene(scene, directory)
        click.echo(f"synthetic scene written to {directory}/ (project: {project_file.name}, truth: truth.json)")
        jobs = 1
    else:
        from data_fixtures.raw_project import RawProjectSpec, make_raw_project

        say = None if quiet else (lambda message: click.echo(f"generating {message}", err=True))
        project_file, scene = make_raw_project(directory, RawProjectSpec(seed=seed), say)
        click.echo(f"raw project written to {directory}/ (project: {project_file.name}, truth: truth.json): videos, checkerboard photos, GCPs, GPX log")
    graph, summary = execute(project_file, None, None, jobs=jobs, quiet=quiet)
    finish(summary)
    timeline = read_timeline(graph.workspace.path("timeline"))
    click.echo("\n" + format_table(timeline))
    table, errors = format_truth_comparison(timeline, scene.truth_pairs(), scene.n_frames)
    click.echo("\nrecovered against true relations:\n" + table)
    click.echo(f"\nworst eps_t: {max(errors.values()):.3f} frames, in {time.perf_counter() - start:.0f} s")
    ws = graph.workspace
    click.echo(f"timeline: {ws.path('timeline')}\nreport: {ws.path('report_html')}\npictures: {ws.path('pictures')}/")
