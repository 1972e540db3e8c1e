"""Geometry helpers shared by the broad phase and the narrow phase."""

from __future__ import annotations

import warp as wp

wp.set_module_options({"enable_backward": False})

EDGE_MARGIN = 1.0e-12  # barycentric distance under which a face point counts as its edge's (float64 rounding: 1e-16)


@wp.func
def closest_point_triangle(p: wp.vec3d, a: wp.vec3d, b: wp.vec3d, c: wp.vec3d) -> wp.vec4d:
    """Closest point of triangle abc to p, in float64 (Ericson, Real-Time Collision Detection 5.1.5).

    Returns (x, y, z, feature) with feature 0 = face interior, 1 = edge, 2 = vertex. A face point within
    ``EDGE_MARGIN`` (barycentric) of an edge is that edge's: rounding can otherwise put a point of an edge inside both
    triangles that share it (it did on CUDA), and the narrow phase merges contacts by feature.
    """
    zero = wp.float64(0.0)
    ab = b - a
    ac = c - a
    ap = p - a
    d1 = wp.dot(ab, ap)
    d2 = wp.dot(ac, ap)
    if d1 <= zero and d2 <= zero:
        return wp.vec4d(a[0], a[1], a[2], wp.float64(2.0))
    bp = p - b
    d3 = wp.dot(ab, bp)
    d4 = wp.dot(ac, bp)
    if d3 >= zero and d4 <= d3:
        return wp.vec4d(b[0], b[1], b[2], wp.float64(2.0))
    vc = d1 * d4 - d3 * d2
    if vc <= zero and d1 >= zero and d3 <= zero:
        v = d1 / (d1 - d3)
        q = a + v * ab
        return wp.vec4d(q[0], q[1], q[2], wp.float64(1.0))
    cp = p - c
    d5 = wp.dot(ab, cp)
    d6 = wp.dot(ac, cp)
    if d6 >= zero and d5 <= d6:
        return wp.vec4d(c[0], c[1], c[2], wp.float64(2.0))
    vb = d5 * d2 - d1 * d6
    if vb <= zero and d2 >= zero and d6 <= zero:
        w = d2 / (d2 - d6)
        q = a + w * ac
        return wp.vec4d(q[0], q[1], q[2], wp.float64(1.0))
    va = d3 * d6 - d5 * d4
    if va <= zero and (d4 - d3) >= zero and (d5 - d6) >= zero:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        q = b + w * (c - b)
        return wp.vec4d(q[0], q[1], q[2], wp.float64(1.0))
    denom = wp.float64(1.0) / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    q = a + ab * v + ac * w
    margin = wp.float64(EDGE_MARGIN)
    if v < margin or w < margin or wp.float64(1.0) - v - w < margin:
        return wp.vec4d(q[0], q[1], q[2], wp.float64(1.0))
    return wp.vec4d(q[0], q[1], q[2], zero)
