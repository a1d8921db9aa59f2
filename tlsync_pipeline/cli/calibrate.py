"""``tlsync calibrate-intrinsics`` (standalone) and the calibrate stage's summary line.

The project-level ``tlsync calibrate`` is a stage command of the pipeline (cli/pipeline.py).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import click

from calibration.choices import MAX_FRAMES, MODELS
from calibration.errors import PatternMismatch
from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.cli.options import jobs_option, out_option, quiet_option, verbose_option
from tlsync_pipeline.errors import InputError, error_details, with_details

if TYPE_CHECKING:
    from calibration.intrinsics import Intrinsics


@click.command("calibrate-intrinsics")
@click.option("--images", help="Checkerboard photos: a glob such as 'boards/*.jpg' (quote it).")
@click.option("--video", type=click.Path(dir_okay=False, path_type=Path), help="A video of a moving checkerboard.")
@click.option("--pattern", required=True, help="Inner corners COLSxROWS, e.g. 7x6 for a board of 8x7 squares.")
@click.option("--square", required=True, type=float, help="Square side in metres.")
@click.option(
    "--model",
    type=click.Choice(MODELS),
    default="standard",
    show_default=True,
    help="standard: k1 k2 p1 p2 k3; rational: 8 coefficients; fisheye: k1..k4.",
)
@out_option("camera.json to write (K, dist, image_size, rms; no pose: R, t come from GCPs, a board or the target).")
@click.option(
    "--report", type=click.Path(dir_okay=False, path_type=Path), help="Also write the calibration report (JSON) here."
)
@click.option("--max-frames", default=MAX_FRAMES, show_default=True, help="Video: frames sampled evenly.")
@jobs_option
@quiet_option("No progress bar.")
@verbose_option
def calibrate_intrinsics(images, video, pattern, square, model, out, report, max_frames, jobs, quiet) -> None:
    """Intrinsics from checkerboard photos or a video, written as a camera.json."""
    from calibration.camera import write_camera
    from calibration.intrinsics import calibrate_images, calibrate_video, parse_pattern

    if (images is None) == (video is None):
        raise InputError("calibrate-intrinsics: give exactly one of --images GLOB or --video FILE")
    board = parse_pattern(pattern, square, source="--pattern")
    try:
        if images is not None:
            result = calibrate_images(images, board, model, workers=jobs, progress=not quiet)
        else:
            result = calibrate_video(video, board, model, max_frames, workers=jobs, progress=not quiet)
    except PatternMismatch as exc:
        raise with_details(InputError(f"{exc}: use --pattern {exc.seen}"), *error_details(exc)) from None
    camera = result.camera(out.stem)
    with atomic_path(out) as tmp:
        write_camera(camera, tmp)
    if report is not None:
        with atomic_path(report) as tmp:
            tmp.write_text(json.dumps(result.to_report(), indent=1) + "\n", encoding="utf-8")
    click.echo(_intrinsics_summary(result))
    for source, reason in result.rejected.items():
        click.echo(f"  rejected {source}: {reason}")
    click.echo(f"wrote {out}")


def _intrinsics_summary(result: Intrinsics) -> str:
    K = result.K
    total = len(result.used) + len(result.rejected)
    return (
        f"{len(result.used)}/{total} views used, RMS {result.rms:.3f} px; "
        f"fx {K[0, 0]:.2f} fy {K[1, 1]:.2f} cx {K[0, 2]:.2f} cy {K[1, 2]:.2f} ({result.model}: dist "
        f"{', '.join(f'{d:.4g}' for d in result.dist)})"
    )
