"""Parameters of the sync stage: those every method shares and, per method, its own.

Each parameter is a dataclass field made with ``param``: its default and the
check the project file applies to it (one of CHECKS). The ``[sync]`` table of
the project file holds the shared keys, ``method`` and every registered
method's own keys (sync/model/methods.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

# Checks a project-file value must pass: "positive" (> 0), "probability" (in (0, 1)),
# "ratio" (in (0, 1]), "non_negative" (>= 0), "finite" (any number), "integer", "boolean".
CHECKS = ("positive", "probability", "ratio", "non_negative", "finite", "integer", "boolean")


def param(default: Any, check: str) -> Any:
    """A parameter field: its default and its check (one of CHECKS)."""
    if check not in CHECKS:
        raise ValueError(f"unknown check {check!r}; one of {', '.join(CHECKS)}")
    return field(default=default, metadata={"check": check})


def parameter_fields(params_type: type) -> dict[str, tuple[Any, str]]:
    """Name -> (default, check) of a parameters dataclass's ``param`` fields."""
    return {f.name: (f.default, f.metadata["check"]) for f in fields(params_type) if "check" in f.metadata}


@dataclass(frozen=True)
class SyncParams:
    """The sync stage's parameters (paper Table 1 defaults).

    eps_px: vote radius (pixels, eq. 3); delta: inlier band around a line in
    the voting space (orthogonal distance, frames); p: probability that the
    line fit draws a good hypothesis (eq. 4); seed: random seed; rate_sigma:
    relative std of a camera's true frame rate against its stated fps (the
    refined method and identification keep each line's slope near fps / log
    rate, sync/kernels/slope.py; 0: free slope, e.g. a time-lapse video whose fps
    is not its capture rate); logged_point_above_m: height of the logged
    point above the tracked point, metres along the world's up axis (a GPS
    at a walker's chest, the blob's centre tracked: about 0.4; negative
    below it), the trajectory lowered by it before voting; log_bias: fit
    the log's bias with the lines when the log's error model has one
    (sync/solve/log_bias.py; false: each camera alone, the log taken as exact);
    upright_roll_deg: a pose from the target without GCPs keeps the
    world's up within this many degrees of the image's up
    (sync/pose/upright.py; 180: any roll, the prior off); method: a
    registered method's name; options: method name -> that method's own
    parameters (an instance of its ``params_type``); a method not listed
    runs with its defaults.
    """

    eps_px: float = param(10.0, "positive")
    delta: float = param(0.5, "positive")
    p: float = param(0.99, "probability")
    seed: int = param(0, "integer")
    rate_sigma: float = param(0.0003, "non_negative")
    logged_point_above_m: float = param(0.0, "finite")
    log_bias: bool = param(True, "boolean")
    # poses fitted right under a phone's 2 m log are rolled up to 23 degrees
    upright_roll_deg: float = param(45.0, "non_negative")
    method: str = "refined"
    options: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Preparation:
    """What preparing the trajectory reads (sync/model/methods.prepare_trajectory), and nothing else.

    method: the sync method's name; options: the method's own preparation
    options (its ``preparation(options)``; None when it prepares nothing);
    logged_point_above_m: as in SyncParams. The vote, identify and render
    stages key their caches on this, not on every [sync] key.
    """

    method: str
    options: Any
    logged_point_above_m: float = 0.0


@dataclass(frozen=True)
class ParamsTable:
    """The flat ``[sync]`` table a fit used (timeline.json's ``params``), typed: the shared keys and ``method`` as
    SyncParams (``options`` empty) and every registered method's own keys by name (``own``; sync/model/methods.py's
    ``params_from_table`` types them)."""

    shared: SyncParams = field(default_factory=SyncParams)
    own: dict[str, Any] = field(default_factory=dict)

    def table(self) -> dict[str, Any]:
        """The flat table: the shared keys and method in SyncParams' order, then the methods' own keys."""
        return {**{name: getattr(self.shared, name) for name in _SHARED}, **self.own}

    @classmethod
    def from_table(cls, table: dict[str, Any]) -> ParamsTable:
        """The typed view of a flat table (shared keys left out take their defaults)."""
        return cls(
            SyncParams(**{k: table[k] for k in _SHARED if k in table}),
            {k: v for k, v in table.items() if k not in _SHARED},
        )


_SHARED = tuple(f.name for f in fields(SyncParams) if f.name != "options")
