"""What the frame rates say about a camera line's slope.

A camera's line clock = alpha * sample + beta has alpha = camera frames per
trajectory sample = fps / log rate, up to the drift between the camera's and
the log's clocks (consumer cameras: tens to hundreds of ppm; a phone's
nominal rate may be off by ~0.1 %). With ``rate_sigma`` (relative std of
that drift) the line search looks for alpha within BAND_SIGMAS of it and the
refinement holds it with a Gaussian prior: a short or sparse track (a 5 fps
camera that sees the target for a few seconds) then cannot tilt its line, and
a passer-by walking along the path at another speed cannot pose as the
target. A long track outweighs the prior and measures the drift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

BAND_SIGMAS = 5.0
# the line search's band is at least alpha x (1 +- this): a stated fps a little off (29.84 for 29.87) stays in it
BAND_FLOOR = 1e-3


@dataclass(frozen=True)
class SlopePrior:
    """alpha: nominal slope (camera frames per trajectory sample); sigma: relative std of the true slope around it."""

    alpha: float
    sigma: float

    @property
    def band(self) -> tuple[float, float]:
        """The slopes the line search considers: alpha x (1 +- max(BAND_SIGMAS x sigma, BAND_FLOOR))."""
        half = max(BAND_SIGMAS * self.sigma, BAND_FLOOR)
        return self.alpha * (1.0 - half), self.alpha * (1.0 + half)


def slope_prior(fps: float | None, rate: float | None, sigma: float) -> SlopePrior | None:
    """The prior of a camera at ``fps`` against a log of ``rate`` samples/s; None when either is
    unknown or sigma is 0.
    """
    if (
        not sigma
        or fps is None
        or rate is None
        or not (math.isfinite(fps) and math.isfinite(rate))
        or fps <= 0
        or rate <= 0
    ):
        return None
    return SlopePrior(fps / rate, min(float(sigma), 0.9 / BAND_SIGMAS))
