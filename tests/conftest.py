"""Shared test setup: Warp on the CPU backend, quiet, and small scene helpers."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True
wp.init()

DEVICE = "cpu"


def square(center: tuple[float, float, float], half: float, normal_tilt_deg: float = 0.0):
    """Two triangles forming a square of side 2*half in the plane z = center_z, tilted about y by the angle given
    (the plane then descends along +x). Returns (vertices (4, 3), faces (2, 3))."""
    c = np.asarray(center, dtype=np.float64)
    v = np.array([[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0], [-half, half, 0.0]])
    t = np.radians(normal_tilt_deg)
    rot = np.array([[np.cos(t), 0.0, np.sin(t)], [0.0, 1.0, 0.0], [-np.sin(t), 0.0, np.cos(t)]])
    return v @ rot.T + c, np.array([[0, 1, 2], [0, 2, 3]])


@pytest.fixture
def device() -> str:
    return DEVICE
