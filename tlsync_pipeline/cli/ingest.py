"""``tlsync ingest-log``: one GPS/odometry log to a trajectory CSV, with a summary.

The project-level ``tlsync ingest`` is a stage command of the pipeline (cli/pipeline.py).
"""

from __future__ import annotations

from pathlib import Path

import click

from tlsync_pipeline.cli.options import out_option, quiet_option, verbose_option
from tlsync_pipeline.ingest.formats import FORMATS
from tlsync_pipeline.ingest.params import DEFAULT_MAX_SPEED_MPS, IngestParams
from tlsync_pipeline.ingest.records import ALTITUDE_REFERENCES


@click.command("ingest-log")
@click.argument("log", type=click.Path(path_type=Path))
@click.option(
    "--format",
    "fmt",
    type=click.Choice(("auto", *FORMATS)),
    default="auto",
    show_default=True,
    help="The log's format.",
)
@click.option(
    "--origin",
    default="first",
    show_default=True,
    help="ENU origin: LAT,LON,ALT (deg, deg, m above the ellipsoid) or 'first' (first fix).",
)
@click.option(
    "--rate", type=click.FloatRange(min=0, min_open=True), help="Output rate in Hz (default: the log's median rate)."
)
@click.option(
    "--max-gap",
    "max_gap_s",
    type=click.FloatRange(min=0, min_open=True),
    help="Longest interval bridged by interpolation, s (default: 3x the median interval).",
)
@click.option(
    "--max-speed",
    "max_speed_mps",
    type=click.FloatRange(min=0, min_open=True),
    default=DEFAULT_MAX_SPEED_MPS,
    show_default=True,
    help="Fixes implying a faster speed are spikes, m/s.",
)
@click.option(
    "--smoothing",
    "smoothing_s",
    type=click.FloatRange(min=0),
    default=0.0,
    show_default=True,
    help="Savitzky-Golay window in seconds (0: none).",
)
@click.option("--topic", help="ROS bag topic (needed when the bag has several; the error lists them).")
@click.option(
    "--altitude-reference",
    type=click.Choice(ALTITUDE_REFERENCES),
    help="What the log's heights are above, when the log says otherwise or nothing (default: as the reader says).",
)
@click.option(
    "--altitude-offset",
    "altitude_offset_m",
    type=float,
    default=0.0,
    show_default=True,
    help="Metres added to every height to make it ellipsoidal (e.g. the geoid undulation for MSL heights).",
)
@click.option(
    "--utc-offset",
    "utc_offset",
    help="Local time - UTC of a log whose clock is local (DJI SRT, the DJI app's CSV): hours (2, -3.5) or +HH:MM.",
)
@out_option("Trajectory CSV to write (report beside it: <stem>.ingest.json).")
@quiet_option("Print nothing but errors.")
@verbose_option
def ingest_log_command(
    log: Path,
    fmt: str,
    origin: str,
    rate,
    max_gap_s,
    max_speed_mps,
    smoothing_s,
    topic,
    altitude_reference,
    altitude_offset_m,
    utc_offset,
    out: Path,
    quiet: bool,
) -> None:
    """Convert one GPS/odometry LOG into a constant-rate local trajectory CSV."""
    from tlsync_pipeline.pipeline.stages.ingest import (
        ingest_log,
        parse_origin,
        parse_utc_offset_option,
        report_sidecar,
        write_ingest,
    )

    params = IngestParams(
        parse_origin(origin),
        rate,
        max_gap_s,
        max_speed_mps,
        smoothing_s,
        altitude_reference=altitude_reference,
        altitude_offset_m=altitude_offset_m,
    )
    trajectory, report = ingest_log(
        log, fmt, params, topic, None if utc_offset is None else parse_utc_offset_option(utc_offset)
    )
    write_ingest(trajectory, report, out, report_sidecar(out))
    if not quiet:
        click.echo(report.summary())
        click.echo(f"wrote {out} and {report_sidecar(out)}")
