"""A camera's own clock as a check on its synchronized offset.

A camera whose video says when it was recorded (a ``ClockPrior``: the UTC of
its time 0, with a tolerance) can be checked against its fitted line: the
line puts the camera's frame 0 at a target sample, hence at a time on the
target log's clock; when that clock is UTC the two times should agree within
the tolerance. A result that disagrees by more is flagged ``CLOCK_FLAG``
(a named reason on the camera, with the numbers in ``clock_prior`` of
timeline.json), never moved to the prior: the prior checks the result, it
does not steer the search, so a wrong prior cannot hide a right answer.
The result's own 95 % half-width (from the line's covariance, when the
method gives one) is added to the tolerance: a disagreement is one beyond
what either side can answer for.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from tlsync_pipeline.artefacts.clock import ClockPrior
from tlsync_pipeline.sync.model.clock import FrameTimes
from tlsync_pipeline.sync.model.status import WEAK, Reason

CLOCK_FLAG = "clock_disagrees"
HALF_95 = 1.96
LEAP_SECONDS = 18.0  # GPS time - UTC since 2017: a log on GPS time is this much ahead


@dataclass(frozen=True)
class ClockCheck:
    """A line against its camera's clock prior. result_utc_s: the line's frame 0 on the target log's UTC (None when
    the log's clock is not UTC: nothing to compare); offset_s: result - prior (s); result_half_width_s: the
    result's 95 % half-width (s, 0 without a covariance); agrees: |offset| within the tolerance plus that half-width
    (None when not compared)."""

    source: str
    prior_utc_s: float
    tolerance_s: float
    result_utc_s: float | None
    offset_s: float | None
    agrees: bool | None
    result_half_width_s: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, entry: dict) -> ClockCheck:
        return cls(**entry)


def check_clock(
    line,
    target_rate: float | None,
    target_t0: float | None,
    log_utc: bool,
    prior: ClockPrior,
    times: FrameTimes | None = None,
) -> ClockCheck:
    """The check of one camera line (tlsync_pipeline.sync.timeline.CameraLine) against its prior.

    target_rate (samples/s) and target_t0 (s on the log's clock) place the
    target's samples in time; log_utc: whether that clock is UTC.
    """
    if not log_utc or target_rate is None or target_t0 is None:
        return ClockCheck(prior.source, prior.utc_s, prior.tolerance_s, None, None, None)
    sample0 = float(line.sample_at(0.0, times))
    result = float(target_t0 + sample0 / target_rate)
    offset = result - prior.utc_s
    half = 0.0
    if line.cov is not None:
        gradient = np.array([-sample0 / line.alpha, -1.0 / line.alpha])  # of (clock(0) - beta) / alpha in (alpha, beta)
        half = HALF_95 * float(np.sqrt(max(gradient @ np.asarray(line.cov) @ gradient, 0.0))) / target_rate
    return ClockCheck(
        prior.source, prior.utc_s, prior.tolerance_s, result, offset, abs(offset) <= prior.tolerance_s + half, half
    )


def with_clock_checks(
    timeline, priors: dict[str, ClockPrior], log_utc: bool, times: dict[str, FrameTimes | None] | None = None
):
    """The timeline (tlsync_pipeline.sync.timeline.Timeline) with each camera that has a prior checked:
    ``clock_check`` set and, when it disagrees, the flag CLOCK_FLAG added to its line."""
    lines = dict(timeline.cameras)
    for name, prior in priors.items():
        if name not in lines:
            continue
        line = lines[name]
        check = check_clock(line, timeline.target_rate, timeline.target_t0, log_utc, prior, (times or {}).get(name))
        flags = tuple(f for f in (line.flags or ()) if f != CLOCK_FLAG)
        if check.agrees is False:
            flags = (*flags, CLOCK_FLAG)
        lines[name] = replace(line, clock_check=check, flags=flags if flags or line.flags is not None else line.flags)
    return replace(timeline, cameras=lines)


def clock_reason(check: ClockCheck) -> Reason:
    """The CLOCK_FLAG reason with its numbers, and the likely cause when the offset is one: a whole number of half
    hours (a clock on local time: ``utc_offset``) or the leap seconds (a log on GPS time, not UTC)."""
    offset = check.offset_s or 0.0
    slack = check.tolerance_s + check.result_half_width_s
    text = (
        f"the result puts the video's time 0 {offset:+.1f} s from the camera's own clock ({check.source}; "
        f"tolerance {check.tolerance_s:g} s)"
    )
    half_hours = round(offset / 1800.0)
    if half_hours and abs(offset - half_hours * 1800.0) <= slack:
        hours = f"{half_hours / 2:+g}"
        return Reason(
            CLOCK_FLAG,
            WEAK,
            f"{text}: {hours} h, a clock on local time",
            f"a log on local time: set [target] utc_offset = {hours}; a camera's: [cameras.clock] utc_offset = "
            f"{-half_hours / 2:+g}",
        )
    for leap in (LEAP_SECONDS, -LEAP_SECONDS):
        if abs(offset - leap) <= slack:
            return Reason(
                CLOCK_FLAG,
                WEAK,
                f"{text}: {leap:+g} s, the leap seconds between GPS time and UTC",
                f"a log on GPS time, not UTC: take {leap:g} s off its times (or its reader's time base), or check the "
                f"camera's clock",
            )
    return Reason(CLOCK_FLAG, WEAK, text, "check the camera's clock and the log's time base")
