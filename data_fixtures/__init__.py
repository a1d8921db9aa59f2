"""Deterministic synthetic scenes with known ground truth, for tests, benches and the demo."""

from data_fixtures.scene import Scene, make_scene, write_scene

__all__ = ["Scene", "make_scene", "write_scene"]
