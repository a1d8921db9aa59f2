"""Output choices a project file may name, without the outputs' libraries (a leaf: no OpenCV, no PyAV)."""

from __future__ import annotations

PROXY_POLICIES = ("auto", "always", "never")  # [render] proxy: a browser-playable copy when needed, always, never
