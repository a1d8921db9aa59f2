"""``tlsync track-video``: one video, its every mover (detections.csv) or one target (track.csv).

The project-level ``tlsync track`` is a stage command of the pipeline (cli/pipeline.py).
"""

from __future__ import annotations

from pathlib import Path

import click

from tlsync_pipeline.cli.options import out_option, quiet_option, verbose_option
from trackers.choices import DEFAULT_KIND, KINDS


def _box(ctx, param, value):
    if value is None:
        return None
    try:
        box = [float(v) for v in value.split(",")]
    except ValueError:
        box = []
    if len(box) != 4:
        raise click.BadParameter(f"expected X,Y,W,H (four numbers, pixels), got {value!r}")
    return box


@click.command("track-video")
@click.argument("video", type=click.Path(path_type=Path))
@click.option(
    "--tracker", "kind", type=click.Choice(KINDS), default=DEFAULT_KIND, show_default=True, help="Tracker kind."
)
@click.option(
    "--init", callback=_box, help="Box X,Y,W,H around the target in the init frame (pixels, top-left corner and size)."
)
@click.option(
    "--init-frame",
    default=0,
    show_default=True,
    type=click.IntRange(min=0),
    help="0-based frame of the init box; tracking starts there.",
)
@out_option("detections.csv (blob, no --init) or track.csv to write.")
@quiet_option("No progress bar.")
@verbose_option
def track_video_command(video: Path, kind: str, init, init_frame: int, out: Path, quiet: bool) -> None:
    """Detect every mover in VIDEO (detections.csv: frame,time_s,id,x,y,w,h,score), or, with --init or
    --tracker csrt, track one target (track.csv: frame,x,y,time_s,w,h,score)."""
    from tlsync_pipeline.pipeline.stages.track import write_detections_atomic, write_track_atomic
    from trackers.detections import follows_every_mover
    from trackers.tracking import detect_movers, track_video

    if follows_every_mover(kind, init, init_frame):
        detections = detect_movers(video, progress=not quiet)
        write_detections_atomic(detections, out)
        click.echo(f"{len(detections)} detections in {len(detections.tracklet_ids())} tracklets; wrote {out}")
        return
    result = track_video(video, kind=kind, init=init, init_frame=init_frame, progress=not quiet)
    write_track_atomic(result, out)
    click.echo(f"{len(result)} tracked frames; wrote {out}")
