"""Shared test setup: Warp on the CPU backend, quiet, and small scene helpers."""

from __future__ import annotations

import os

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True
wp.init()

#: tests run on Warp's CPU backend; WARPDEM_TEST_DEVICE=cuda runs the same suite on a GPU
DEVICE = os.environ.get("WARPDEM_TEST_DEVICE", "cpu")


def quasi_static_bin(springs: list[int], speeds: list[float], draught: list[float], stiffness: list[float],
                     sem: float = 0.5, arm_ratio: float = 2.5) -> object:
    """A quasi-static soil bin's run (written for the tests, not warpdem's DEM), as ``scenes.soil_bin.SoilBinRun``:
    world w draws ``draught[w]`` [N] (standard error ``sem`` [N]) and its tool deflects by the moment balance
    x = F (h / a) / k at the sensor, ``arm_ratio`` = h / a (the draught's depth below the pivot over the spring's and
    sensor's lever), k = ``stiffness[w]`` [N/m] (inf: the rigid tool); steady from the start, no drift."""
    from scenes import soil_bin as sb

    steady = [{"springs": n, "speed": v, "draught_mean": f, "draught_sem": sem,
               "displacement_mean": f * arm_ratio / k, "displacement_sem": 1e-5, "displacement_trend": 0.0,
               "displacement_trend_sem": 1e-5, "steady_time_mean": 1.0}
              for n, v, f, k in zip(springs, speeds, draught, stiffness, strict=True)]
    t = np.linspace(0.0, 1.0, 5)
    series = {"displacement": np.tile([r["displacement_mean"] for r in steady], (len(t), 1)),
              "draught": np.tile([r["draught_mean"] for r in steady], (len(t), 1))}
    return sb.SoilBinRun(tuple(springs), tuple(speeds), t, np.outer(t, speeds), series, steady)


def square(center: tuple[float, float, float], half: float, normal_tilt_deg: float = 0.0):
    """Two triangles forming a square of side 2*half in the plane z = center_z, tilted about y by the angle given
    (the plane then descends along +x). Returns (vertices (4, 3), faces (2, 3))."""
    c = np.asarray(center, dtype=np.float64)
    v = np.array([[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0], [-half, half, 0.0]])
    t = np.radians(normal_tilt_deg)
    rot = np.array([[np.cos(t), 0.0, np.sin(t)], [0.0, 1.0, 0.0], [-np.sin(t), 0.0, np.cos(t)]])
    return v @ rot.T + c, np.array([[0, 1, 2], [0, 2, 3]])


@pytest.fixture
def full_workflow_start(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture):
    """`warpdem reproduce --workflow full` (ci scale, assembly A, 16 springs, CPU) stopped where its workflow would
    start running: ``start(out, *options)`` claims ``out`` as the command does, asserts the command ends as
    interrupted (exit 130) and returns the ``WorkflowConfig`` it would have run."""
    from calibration import cli
    from calibration import paper_workflow as pw

    seen: list[object] = []

    def stop(self: pw.Workflow, budget: object) -> None:
        seen.append(self.config)
        raise KeyboardInterrupt

    monkeypatch.setattr(pw.Workflow, "run", stop)

    def start(out: object, *options: str) -> object:
        args = ["reproduce", "--workflow", "full", "--scale", "ci", "--assembly", "A", "--springs", "16",
                "--device", "cpu", "--out", str(out), *options]
        assert cli.main(args) == 130, args
        capsys.readouterr()
        return seen[-1]

    return start


@pytest.fixture
def device() -> str:
    return DEVICE


def point_triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Exact distance from points p to triangles abc, all broadcast (..., 3), by projection onto the plane when
    the projection is inside, else the nearest of the three edges (an independent host-side reference)."""
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    h = np.sum((p - a) * n, axis=-1)
    q = p - h[..., None] * n
    inside = np.ones(np.broadcast_shapes(p.shape, a.shape)[:-1], dtype=bool)
    for e0, e1 in ((a, b), (b, c), (c, a)):
        inside &= np.sum(np.cross(e1 - e0, q - e0) * n, axis=-1) >= 0
    best = np.abs(h)
    edge = np.full_like(best, np.inf)
    for e0, e1 in ((a, b), (b, c), (c, a)):
        d = e1 - e0
        s = np.clip(np.sum((p - e0) * d, axis=-1) / np.sum(d * d, axis=-1), 0.0, 1.0)
        edge = np.minimum(edge, np.linalg.norm(p - (e0 + s[..., None] * d), axis=-1))
    return np.where(inside, best, edge)
