"""What is known of the target log's error: white noise per fix, and a bias that wanders slowly.

A receiver's position error is white noise (the per-fix accuracy a log
states, or ``white_m``) plus a bias that wanders over a minute or so: a
first-order Gauss-Markov process per axis, standard deviation ``bias_m``
(horizontal) and ``bias_vertical_m``, correlation time ``tau_s``. An RTK
log has neither to speak of; a consumer drone's or a phone's has metres of
bias. Presets are named by the receivers users carry (docs/algorithm.md,
"The log's error"); ingest suggests one from the log's format and quality.
A preset is a prior, not a verdict: the white noise is measured on the
log's own fixes (sync/vote/log_error.py's ``measured``), the bias's std and correlation time by the
joint fit's marginal likelihood (sync/solve/log_bias.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

DRIFT_WINDOW_S = 0.5  # seconds over which the bias's drift speed is taken (LogModel.drift_m_s)


@dataclass(frozen=True)
class LogModel:
    """A log's error model (metres, seconds): white std per fix when the log states none, and the Gauss-Markov
    bias (horizontal and vertical std, correlation time); ``name``: the preset it came from, or "custom"."""

    name: str
    white_m: float = 0.0
    bias_m: float = 0.0
    bias_vertical_m: float = 0.0
    tau_s: float = 60.0
    measured: tuple[str, ...] = ()  # the fields measured from the data (the preset's values their prior)
    suggested: bool = False  # the preset is what ingest suggests from the log's kind, not the project's declaration

    @property
    def has_bias(self) -> bool:
        return self.bias_m > 0 or self.bias_vertical_m > 0

    def unabsorbed_m(self, duration_s: float) -> float:
        """Std (metres, per axis, horizontal and vertical pooled) of the error a fixed pose cannot absorb over a visit
        of
        ``duration_s``: the white noise and the bias's wander about its mean over the visit (a constant offset of the
        log is a shift of the camera's centre, which the pose takes; a first-order Gauss-Markov bias keeps
        1 - 2 (x - 1 + exp(-x)) / x^2 of its variance about a window of x correlation times)."""
        x = max(duration_s, 0.0) / self.tau_s if self.tau_s > 0 else math.inf
        kept = 0.0 if x <= 0 else 1.0 if math.isinf(x) else 1.0 - 2.0 * (x - 1.0 + math.exp(-x)) / x**2
        return math.sqrt(self.white_m**2 + kept * (self.bias_m**2 + self.bias_vertical_m**2) / 2.0)

    def drift_m_s(self, rate: float) -> float:
        """How fast (metres per second, 3D std) the bias alone moves a log of ``rate`` fixes per second: its change
        over DRIFT_WINDOW_S or two fixes, the longer (a first-order Gauss-Markov process keeps
        2 (1 - exp(-w / tau)) of its variance in a change over w), over that window. A log smoothed as the sync
        smooths it keeps that speed where its target is still (drone2 hovering at 0.1 m/s under a drone's error: its
        log's median speed 0.7 m/s, this 0.9); 0 without a bias."""
        if not self.has_bias or rate <= 0:
            return 0.0
        window = max(DRIFT_WINDOW_S, 2.0 / rate)
        kept = 2.0 * (1.0 - math.exp(-window / self.tau_s)) if self.tau_s > 0 else 2.0
        return math.sqrt(kept * (2.0 * self.bias_m**2 + self.bias_vertical_m**2)) / window

    @property
    def horizontal_m(self) -> float:
        """Total horizontal std of a fix's error (white and bias), metres."""
        return math.hypot(self.white_m, self.bias_m)

    @property
    def vertical_m(self) -> float:
        """Total vertical std of a fix's error (white and bias), metres."""
        return math.hypot(self.white_m, self.bias_vertical_m)


def log_drift(model: LogModel, rate: float | None) -> float:
    """How fast the log's bias alone moves its positions (metres per sample, ``LogModel.drift_m_s``); 0 without a
    bias or a log rate."""
    return model.drift_m_s(rate) / rate if rate else 0.0


PRESETS: dict[str, LogModel] = {
    "none": LogModel("none"),
    "rtk": LogModel("rtk", 0.02),
    "white": LogModel("white", 0.3),
    "drone": LogModel("drone", 0.1, 1.0, 2.0, 30.0),
    "phone": LogModel("phone", 0.5, 2.0, 4.0, 60.0),
}


AUTO = "auto"
PRIOR_LOG_SD = math.log(3.0)  # a preset's value is known to within a factor of 3 (one std of its logarithm)


@dataclass(frozen=True)
class LogModelChoice:
    """[target]'s choice of the log's error model: a preset name, or "auto" (what ingest suggests from the log's kind;
    "none" for a trajectory the project brings), and overrides (metres, seconds; None: the preset's). An override of
    the bias sets the vertical one to twice it, as the presets have it."""

    name: str = AUTO
    white_m: float | None = None
    bias_m: float | None = None
    tau_s: float | None = None

    @property
    def for_vote_radius(self) -> LogModelChoice:
        """The choice without the bias's correlation time, which vote_radius and measured (sync/vote/log_error.py)
        do not read: the vote and identify stages key their caches on this, so that tau_s re-runs sync alone."""
        return replace(self, tau_s=None)

    def resolve(self, suggested: str | None) -> LogModel:
        """The model: the preset chosen (``suggested`` for "auto", marked as a suggestion; "none" without one) with the
        overrides (a declaration)."""
        base = PRESETS[(suggested or "none") if self.name == AUTO else self.name]
        if self.white_m is None and self.bias_m is None and self.tau_s is None:
            return replace(base, suggested=True) if self.name == AUTO and suggested is not None else base
        bias = base.bias_m if self.bias_m is None else self.bias_m
        return LogModel(
            "custom",
            base.white_m if self.white_m is None else self.white_m,
            bias,
            base.bias_vertical_m if self.bias_m is None else 2.0 * bias,
            base.tau_s if self.tau_s is None else self.tau_s,
        )
