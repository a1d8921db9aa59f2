"""The sync methods as the project file and the trajectory's preparation see them: name, own parameters, preparation.

A method (sync/solve/methods.py's SyncMethod) is declared here by what
every stage before the fit reads of it: its name (the ``[sync] method``
value), its parameters (``params_type``, a frozen dataclass whose ``param``
fields, sync/model/params.py, are its own ``[sync]`` keys) and how it
prepares the trajectory the votes are cast on. Its fit is registered in
sync/solve/registry.py, whose ``register`` also declares a new method here.
So the project file, the scan, calibrate, identify, vote and render stages
know every method without importing any fit (their cache keys leave the
fits out).
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass, fields, replace
from typing import Any, Protocol

import numpy as np

from tlsync_pipeline.sync.kernels.smoothing import smooth_trajectory
from tlsync_pipeline.sync.model.params import Preparation, SyncParams, param, parameter_fields
from tlsync_pipeline.trajectory import Trajectory, lowered


class MethodKind(Protocol):
    """What a sync method is before its fit: name, params_type, and its preparation of the trajectory."""

    @property
    def name(self) -> str: ...

    @property
    def params_type(self) -> type: ...

    def preparation(self, options: Any) -> Any:
        """The part of the method's ``options`` that prepare_trajectory reads (a frozen dataclass), or None."""
        ...

    def prepare_trajectory(self, trajectory: Trajectory, preparation: Any) -> Trajectory:
        """The trajectory votes are cast on and the line is fitted to (the vote stage and render use it too)."""
        ...


@dataclass(frozen=True)
class PaperParams:
    """r: the expected inlier ratio of the votes, which sets the RANSAC iteration count (eq. 4)."""

    r: float = param(0.05, "ratio")


class PaperKind:
    """The "paper" method (sync/solve/paper.py) before its fit: the trajectory as logged."""

    name = "paper"
    params_type = PaperParams

    def preparation(self, options: PaperParams) -> None:
        """Nothing: the trajectory is used as logged."""
        return None

    def prepare_trajectory(self, trajectory: Trajectory, preparation: None) -> Trajectory:
        """The logged trajectory, unchanged."""
        return trajectory


@dataclass(frozen=True)
class RefinedParams:
    """r_min: smallest inlier ratio the line search must find; f_scale_px: robust loss
    scale of the refinement (pixels); smooth_trajectory: smooth the logged trajectory
    first; model_error_px: pixel error of the calibration and pose that the
    intervals allow for (the log's white noise is counted from its own sigma)."""

    r_min: float = param(0.01, "ratio")
    f_scale_px: float = param(3.0, "positive")
    smooth_trajectory: bool = param(True, "boolean")
    model_error_px: float = param(1.0, "non_negative")


@dataclass(frozen=True)
class Smoothing:
    """The refined method's trajectory preparation: smooth the logged trajectory or not
    (RefinedParams.smooth_trajectory).
    """

    smooth_trajectory: bool


class RefinedKind:
    """The "refined" method (sync/solve/refined.py) before its fit: the trajectory smoothed run by run."""

    name = "refined"
    params_type = RefinedParams

    def preparation(self, options: RefinedParams) -> Smoothing:
        return Smoothing(options.smooth_trajectory)

    def prepare_trajectory(self, trajectory: Trajectory, preparation: Smoothing) -> Trajectory:
        """The trajectory smoothed run by run (unless smooth_trajectory is off)."""
        return smooth_trajectory(trajectory) if preparation.smooth_trajectory else trajectory


METHODS: dict[str, MethodKind] = {}


def declare(method: MethodKind) -> MethodKind:
    """Add a method's declaration; ValueError when its name or one of its parameter names is taken."""
    if method.name in METHODS:
        raise ValueError(f"a sync method named {method.name!r} is already registered")
    taken = set(parameter_fields(SyncParams)) | {"method"}
    for other in METHODS.values():
        taken |= set(parameter_fields(other.params_type))
    clash = taken & set(parameter_fields(method.params_type))
    if clash:
        raise ValueError(
            f"sync method {method.name!r}: parameter(s) {', '.join(sorted(clash))} already used by another method or "
            f"shared"
        )
    METHODS[method.name] = method
    return method


def declared(name: str) -> MethodKind:
    """The declared method ``name``; ValueError listing the names otherwise."""
    if name not in METHODS:
        raise ValueError(f"unknown sync method {name!r}; methods: {', '.join(METHODS)}")
    return METHODS[name]


def method_options(params: SyncParams) -> Any:
    """The chosen method's own parameters: those given in ``params.options``, else its defaults."""
    method = declared(params.method)
    return params.options.get(method.name) or method.params_type()


def params_table(params: SyncParams) -> dict[str, Any]:
    """The flat ``[sync]`` table of ``params``: shared keys, method, every registered method's keys (timeline.json,
    cache keys).
    """
    table = {f.name: getattr(params, f.name) for f in fields(SyncParams) if f.name != "options"}
    for name, method in METHODS.items():
        table.update(asdict(params.options.get(name) or method.params_type()))
    return table


def preparation_of(params: SyncParams) -> Preparation:
    """What preparing the trajectory reads of ``params``: the method, its preparation options, logged_point_above_m."""
    method = declared(params.method)
    return Preparation(method.name, method.preparation(method_options(params)), params.logged_point_above_m)


def prepare_trajectory(trajectory: Trajectory, preparation: Preparation) -> Trajectory:
    """The trajectory the chosen method votes on and fits to (vote stage, sync and render all use this), lowered to the
    tracked point by ``logged_point_above_m``.

    The last one prepared in this process is kept (its arrays read-only) and given again for the same trajectory and
    preparation: a worker runs the scan, calibrate, identify and vote stages of several cameras on one trajectory
    (the refined method's smoothing: about 40 ms for 800 samples).
    """
    key = (_digest(trajectory), preparation)
    if _LAST_PREPARED and _LAST_PREPARED[0][0] == key:
        return _LAST_PREPARED[0][1]
    prepared = declared(preparation.method).prepare_trajectory(trajectory, preparation.options)
    prepared = _read_only(
        lowered(prepared, preparation.logged_point_above_m) if preparation.logged_point_above_m else prepared
    )
    _LAST_PREPARED[:] = [(key, prepared)]
    return prepared


_LAST_PREPARED: list[tuple[tuple, Trajectory]] = []  # prepare_trajectory's last (key, prepared trajectory)


def _digest(trajectory: Trajectory) -> tuple:
    """What tells trajectories apart: their arrays' bytes (BLAKE2b), rate and t0."""
    h = hashlib.blake2b(digest_size=16)
    for array in (trajectory.sample, trajectory.xyz, trajectory.sigma):
        if array is None:
            h.update(b"none")
        else:
            array = np.ascontiguousarray(array)
            h.update(f"{array.dtype.str}{array.shape}".encode())
            h.update(array.data)
    return h.hexdigest(), trajectory.rate, trajectory.t0


def _read_only(trajectory: Trajectory) -> Trajectory:
    """A copy of the trajectory whose arrays cannot be written (it is handed to every caller of the same key)."""

    def frozen(array: np.ndarray) -> np.ndarray:
        array = np.array(array)
        array.flags.writeable = False
        return array

    sigma = None if trajectory.sigma is None else frozen(trajectory.sigma)
    return replace(trajectory, sample=frozen(trajectory.sample), xyz=frozen(trajectory.xyz), sigma=sigma)


def params_from_table(table: dict[str, Any]) -> SyncParams:
    """SyncParams from a flat ``[sync]`` table (keys left out take their defaults)."""
    shared = {k: table[k] for k in list(parameter_fields(SyncParams)) + ["method"] if k in table}
    options = {}
    for name, method in METHODS.items():
        own = {k: table[k] for k in parameter_fields(method.params_type) if k in table}
        options[name] = method.params_type(**own)
    return SyncParams(**shared, options=options)


declare(PaperKind())
declare(RefinedKind())
