"""Errors of real position logs, to add to a true trajectory: white noise and a slowly wandering bias.

A consumer receiver's error is not white: it is a bias that wanders over a
minute or so (multipath, atmosphere, the satellites in view), modelled as a
first-order Gauss-Markov process per axis (standard deviation ``sigma_m``,
correlation time ``tau_s``), with white noise on top. Presets follow the
receivers users carry; horizontal and vertical axes have their own sigmas.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LogErrorModel:
    """A log's error: per fix, white noise (metres, horizontal and vertical std) plus a Gauss-Markov bias
    (horizontal and vertical std in metres, correlation time in seconds; 0 std: none); rate: fixes per second."""

    name: str
    rate_hz: float
    white_h_m: float
    white_v_m: float
    bias_h_m: float = 0.0
    bias_v_m: float = 0.0
    tau_s: float = 60.0


PRESETS = {
    "rtk": LogErrorModel("rtk", 10.0, 0.02, 0.03),
    "white": LogErrorModel("white", 1.0, 0.3, 0.3),
    "drone": LogErrorModel("drone", 10.0, 0.1, 0.2, 1.0, 2.0, 30.0),
    "phone": LogErrorModel("phone", 1.0, 0.5, 1.0, 1.0, 2.0, 60.0),
    "phone2": LogErrorModel("phone2", 1.0, 0.5, 1.0, 2.0, 4.0, 60.0),
}


def gauss_markov(rng: np.random.Generator, t: np.ndarray, sigma: np.ndarray, tau_s: float) -> np.ndarray:
    """(N, len(sigma)) samples of stationary first-order Gauss-Markov processes at increasing times
    t (s), one per axis.
    """
    sigma = np.asarray(sigma, dtype=np.float64)
    out = np.empty((len(t), len(sigma)))
    out[0] = rng.normal(0.0, sigma)
    for k in range(1, len(t)):
        keep = np.exp(-(t[k] - t[k - 1]) / tau_s)
        out[k] = keep * out[k - 1] + np.sqrt(1.0 - keep**2) * rng.normal(0.0, sigma)
    return out


def log_errors(rng: np.random.Generator, t: np.ndarray, model: LogErrorModel) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) position errors (ENU metres) of fixes at times t (s) under ``model``, and (N, 3) the bias part of them."""
    bias = np.zeros((len(t), 3))
    if model.bias_h_m > 0 or model.bias_v_m > 0:
        bias = gauss_markov(rng, t, np.array([model.bias_h_m, model.bias_h_m, model.bias_v_m]), model.tau_s)
    white = rng.normal(0.0, 1.0, (len(t), 3)) * [model.white_h_m, model.white_h_m, model.white_v_m]
    return bias + white, bias
