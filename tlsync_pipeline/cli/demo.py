"""``tlsync demo``: a generated project run end to end, recovered against true relations.

By default the project is raw, as users bring it (three cameras at 30, 25 and
15 fps with H.264 videos, checkerboard photos, geodetic ground control
points, a GPX log of the target), so every stage runs: calibrate, track,
ingest, vote, sync, export, render. ``--quick`` uses the synthetic scene with
ready-made calibrations and tracks instead (seconds, no video).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import click

from tlsync_pipeline.cli.console import shown
from tlsync_pipeline.cli.options import jobs_option, quiet_option, verbose_option
from tlsync_pipeline.cli.pipeline import execute, print_timeline, report_outcome
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.outputs.summary import format_truth_comparison
from tlsync_pipeline.pipeline.cache import file_sha256
from tlsync_pipeline.sync.timeline import read_truth

MARKER = ".tlsync-demo.json"  # what the demo wrote: its options and the hash of every file


@click.command("demo")
@click.argument(
    "directory", required=False, type=click.Path(file_okay=False, path_type=Path), default=Path("tlsync-demo")
)
@click.option(
    "--quick", is_flag=True, help="Synthetic calibrations and tracks instead of raw videos, photos and logs (seconds)."
)
@click.option("--seed", default=0, show_default=True, help="Scene seed.")
@click.option("--tracking-noise", default=1.0, show_default=True, help="With --quick: tracking noise S_t (pixels).")
@jobs_option
@click.option(
    "--overwrite",
    is_flag=True,
    help="Write the project even over files in DIRECTORY that the demo did not write or that were edited.",
)
@quiet_option()
@verbose_option
def demo(
    directory: Path, quick: bool, seed: int, tracking_noise: float, jobs: int | None, overwrite: bool, quiet: bool
) -> None:
    """Generate a three-camera project in DIRECTORY, run the pipeline on it, compare with the truth.

    An existing DIRECTORY is used again when it holds this very demo,
    untouched; it is not overwritten when it holds other or edited files
    (unless --overwrite).
    """
    start = time.perf_counter()
    options = {"quick": quick, "seed": seed, "tracking_noise": tracking_noise if quick else None}
    if quick:
        jobs = 1
    project_file = directory / "project.toml"
    if overwrite or not _same_demo(directory, options):
        project_file = _generate(directory, options, quiet)
    else:
        click.echo(f"{directory}/ holds this demo's project, untouched: running it again")
    graph, summary = execute(project_file, None, jobs=jobs, quiet=quiet)
    code = report_outcome(graph, summary, quiet)
    timeline = print_timeline(graph, summary)
    if timeline is not None:
        pairs, n_frames = read_truth(directory / "truth.json")
        table, errors = format_truth_comparison(timeline, pairs, n_frames)
        click.echo("\nrecovered against true relations:\n" + table)
        failed = len(pairs) - len(errors)
        if errors:
            click.echo(
                f"\nworst eps_t: {max(errors.values()):.3f} frames"
                + (f" ({failed} pairs failed)" if failed else "")
                + f", in {time.perf_counter() - start:.0f} s"
            )
        ws = graph.workspace
        click.echo(
            shown(
                f"timeline: {ws.path('timeline')}\nreport: {ws.path('report_html')}\npictures: {ws.path('pictures')}/"
            )
        )
    if code:
        sys.exit(code)


def _generate(directory: Path, options: dict, quiet: bool) -> Path:
    """Write the demo project into ``directory`` and the marker listing what was written; returns project.toml."""
    if options["quick"]:
        from data_fixtures.scene import make_scene, write_scene

        scene = make_scene(
            options["seed"],
            lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)),
            n_frames=(512, 512, 300),
            tracking_noise_px=options["tracking_noise"],
        )
        project_file = write_scene(scene, directory)
        click.echo(f"synthetic scene written to {directory}/ (project: {project_file.name}, truth: truth.json)")
    else:
        from data_fixtures.raw_project import RawProjectSpec, make_raw_project

        say = None if quiet else (lambda message: click.echo(f"generating {message}", err=True))
        project_file, _ = make_raw_project(directory, RawProjectSpec(seed=options["seed"]), say)
        click.echo(
            f"raw project written to {directory}/ (project: {project_file.name}, truth: truth.json): videos, "
            f"checkerboard photos, GCPs, GPX log"
        )
    (directory / MARKER).write_text(
        json.dumps({"options": options, "files": _hashes(directory)}, indent=1) + "\n", encoding="utf-8"
    )
    return project_file


def _same_demo(directory: Path, options: dict) -> bool:
    """Whether ``directory`` holds the demo made with ``options``, untouched (False: absent, empty, or another demo).

    InputError when it holds files the demo did not write, or demo files edited since.
    """
    files = _hashes(directory, hash_files=False)
    if not files:
        return False
    marker = directory / MARKER
    if not marker.exists():
        raise InputError(
            f"{directory}: the folder holds files that tlsync demo did not write (such as {next(iter(files))}); "
            "give another folder, or --overwrite to write the demo over them"
        )
    record = json.loads(marker.read_text(encoding="utf-8"))
    now = _hashes(directory)
    edited = [name for name, digest in record["files"].items() if now.get(name) != digest]
    if edited:
        raise InputError(
            f"{directory}: {edited[0]} was edited or deleted since tlsync demo wrote it"
            + (f" (and {len(edited) - 1} more)" if len(edited) > 1 else "")
            + "; give another folder, or --overwrite to write the demo again"
        )
    return record["options"] == options


def _hashes(directory: Path, hash_files: bool = True) -> dict[str, str]:
    """Relative path -> SHA-256 of every file in ``directory`` outside its work folder and the marker."""
    from tlsync_pipeline.pipeline.project import WORK_DIR_NAME

    if not directory.is_dir():
        return {}
    out = {}
    for path in sorted(p for p in directory.rglob("*") if p.is_file()):
        relative = path.relative_to(directory)
        if relative.parts[0] not in (WORK_DIR_NAME, MARKER):
            out[relative.as_posix()] = file_sha256(path) if hash_files else ""
    return out
