"""Every mover: the blob detector's candidates linked into tracklets.

Per frame, each live tracklet predicts its position with a constant-velocity
model (velocity smoothed over its last moves); the cost of linking tracklet
i to candidate j is (distance / gate)^2 + (log area ratio / log size_ratio)^2,
and pairs further than the gate, of a too different size or of the other
polarity (brighter / darker than the background) cannot be linked. The
assignment minimising the total cost (scipy.optimize.linear_sum_assignment)
links them; a candidate left over starts a new tracklet; a tracklet without
a candidate for more than ``patience`` frames ends. The gate grows with the
frames since the tracklet was last seen and with the object's size
(half its larger side).

Why scipy rather than a tracking library: the motion model and the gate
take a few lines here, the detector's blobs are already in hand, and
scipy is already a dependency; libraries such as motpy or norfair wrap the
same assignment with detector formats and Kalman settings of their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from trackers.blob import Blob, BlobParams

_INFEASIBLE = 1e6
SMOOTHING = 0.6  # weight of the newest move in the velocity estimate


@dataclass
class _Tracklet:
    id: int
    x: float
    y: float
    vx: float
    vy: float
    area: float
    polarity: int
    frame: int
    hits: int


class MoverLinker:
    """Links each frame's blobs to tracklets; ``step`` returns (tracklet id, blob, score) per blob.

    score in (0, 1]: exp(-link cost) for a blob that continues a tracklet,
    0.5 for one that starts a tracklet.
    """

    def __init__(self, params: BlobParams = BlobParams()):
        self.params = params
        self.live: list[_Tracklet] = []
        self.next_id = 0

    def step(self, frame: int, blobs: list[Blob]) -> list[tuple[int, Blob, float]]:
        p = self.params
        self.live = [t for t in self.live if frame - t.frame <= p.patience]
        out: list[tuple[int, Blob, float]] = []
        linked = set()
        if self.live and blobs:
            from scipy.optimize import (
                linear_sum_assignment,
            )  # 0.4-0.5 s to import: paid by the processes that link, not by every one importing trackers

            cost = self._costs(frame, blobs)
            rows, cols = linear_sum_assignment(cost)
            for i, j in zip(rows, cols):
                if cost[i, j] >= _INFEASIBLE:
                    continue
                self._update(self.live[i], blobs[j], frame)
                out.append((self.live[i].id, blobs[j], math.exp(-cost[i, j])))
                linked.add(j)
        for j, b in enumerate(blobs):
            if j not in linked:
                self.live.append(_Tracklet(self.next_id, b.x, b.y, 0.0, 0.0, b.area, b.polarity, frame, 1))
                out.append((self.next_id, b, 0.5))
                self.next_id += 1
        return out

    def _costs(self, frame: int, blobs: list[Blob]) -> np.ndarray:
        """(live tracklets x blobs) link costs, _INFEASIBLE where they cannot be linked."""
        p = self.params
        log_ratio_max = math.log(p.size_ratio)
        blob_cols = np.array([(b.x, b.y, max(b.area, 1e-6), b.polarity, max(b.w, b.h)) for b in blobs]).T
        bx, by, barea, bpol, bsize = (c[None, :] for c in blob_cols)
        tx, ty, tvx, tvy, tarea, tpol, tframe = (
            c[:, None] for c in np.array([(t.x, t.y, t.vx, t.vy, t.area, t.polarity, t.frame) for t in self.live]).T
        )
        dt = frame - tframe
        gate = np.maximum(p.gate_px, 0.5 * bsize) * (1 + 0.5 * (dt - 1))
        dist = np.hypot(bx - (tx + tvx * dt), by - (ty + tvy * dt))
        ratio = np.abs(np.log(barea / tarea))
        cost = (dist / gate) ** 2 + (ratio / log_ratio_max) ** 2
        ok = (dist <= gate) & (ratio <= log_ratio_max) & (bpol == tpol)
        return np.where(ok, cost, _INFEASIBLE)

    @staticmethod
    def _update(t: _Tracklet, b: Blob, frame: int) -> None:
        dt = frame - t.frame
        if t.hits >= 1:
            t.vx = SMOOTHING * (b.x - t.x) / dt + (1 - SMOOTHING) * t.vx if t.hits > 1 else (b.x - t.x) / dt
            t.vy = SMOOTHING * (b.y - t.y) / dt + (1 - SMOOTHING) * t.vy if t.hits > 1 else (b.y - t.y) / dt
        t.area = 0.8 * t.area + 0.2 * b.area
        t.x, t.y, t.frame = b.x, b.y, frame
        t.hits += 1
