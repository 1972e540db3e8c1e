"""Mass properties of rigid bodies: spheres, clumps (Yade's rule) and triangle meshes, and principal axes.

Conventions: an inertia tensor is the 3x3 matrix I = sum m (|r|^2 1 - r r^T) [kg m^2] about the centre of mass,
in the world frame; its off-diagonal entries are the NEGATIVE products of inertia (I_xy = -sum m x y). A body
stores its principal moments and the rotation (quaternion x, y, z, w) from its principal frame to the world.
"""

from __future__ import annotations

import numpy as np

from .errors import InputError, check_finite, check_points, check_positive


def sphere_mass(radius: float, density: float) -> tuple[float, float]:
    """Mass [kg] and moment of inertia [kg m^2] of a solid sphere: m = rho 4/3 pi r^3, I = 2/5 m r^2."""
    m = density * 4.0 / 3.0 * np.pi * radius**3
    return m, 0.4 * m * radius**2


def clump_mass(centres: np.ndarray, radii: np.ndarray, densities: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Yade's clump rule: mass = sum of member masses (overlaps counted twice), inertia by parallel axes.

    Args:
        centres: member centres [m], shape (k, 3).
        radii: member radii [m], shape (k,).
        densities: member densities [kg/m^3], shape (k,).

    Returns:
        (mass [kg], centre of mass [m] shape (3,), inertia tensor about the centre of mass [kg m^2] shape (3, 3)).
    """
    radii = np.asarray(radii, dtype=np.float64).reshape(-1)
    mass, com, inertia = clumps_mass(centres, radii, np.asarray(densities, dtype=np.float64), np.array([len(radii)]))
    return float(mass[0]), com[0], inertia[0]


def clumps_mass(centres: np.ndarray, radii: np.ndarray, densities: np.ndarray, sizes: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`clump_mass` of many clumps at once (a clump's members summed one after the other, as Yade does).

    Args:
        centres: member centres [m], shape (n, 3), clump after clump. radii: [m] (n,). densities: [kg/m^3] (n,).
        sizes: members per clump (c,), summing to n.

    Returns:
        (masses [kg] (c,), centres of mass [m] (c, 3), inertia tensors about them [kg m^2] (c, 3, 3)).
    """
    centres = np.asarray(centres, dtype=np.float64)
    sizes = np.asarray(sizes, dtype=np.int64)
    first = np.r_[0, np.cumsum(sizes)[:-1]]
    masses = densities * 4.0 / 3.0 * np.pi * radii**3
    mass = np.empty(len(sizes))
    com = np.empty((len(sizes), 3))
    inertia = np.empty((len(sizes), 3, 3))
    eye = np.eye(3)
    for k in np.unique(sizes):  # the clumps of k members as (c_k, k) blocks
        rows = np.flatnonzero(sizes == k)
        idx = first[rows][:, None] + np.arange(k)
        m, r, x = masses[idx], radii[idx], centres[idx]
        total, moment = m[:, 0].copy(), m[:, 0, None] * x[:, 0]
        for j in range(1, k):
            total += m[:, j]
            moment += m[:, j, None] * x[:, j]
        c = x - (moment / total[:, None])[:, None, :]
        acc = np.zeros((len(rows), 3, 3))
        for j in range(k):
            cj, mj = c[:, j], m[:, j, None, None]
            dot = np.einsum("ij,ij->i", cj, cj)[:, None, None]
            own = (0.4 * m[:, j] * r[:, j] ** 2)[:, None, None] * eye
            acc += own + mj * (dot * eye - cj[:, :, None] * cj[:, None, :])
        mass[rows], com[rows], inertia[rows] = total, moment / total[:, None], acc
    return mass, com, inertia


def mesh_mass(vertices: np.ndarray, faces: np.ndarray, density: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass properties of a closed triangle mesh of uniform density, computed by trimesh.

    Args:
        vertices: [m], shape (nv, 3). faces: vertex indices, shape (nf, 3). density: [kg/m^3].

    Returns:
        (mass [kg], centre of mass [m] (3,), inertia tensor about the centre of mass, world axes [kg m^2] (3, 3)).
    """
    import trimesh

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    if not mesh.is_watertight:
        raise InputError("mesh must be closed (watertight) to compute its mass properties; give mass, com and inertia")
    mesh.density = density
    return float(mesh.mass), np.asarray(mesh.center_mass, dtype=np.float64), np.asarray(mesh.moment_inertia)


def rows_times(p: np.ndarray, m: np.ndarray) -> np.ndarray:
    """``p @ m`` for rows p (..., 3) and a 3x3 matrix m, in element-wise arithmetic (machine-independent bits).

    numpy's ``@`` and ``dot`` of float64 go to BLAS, whose kernels (chosen by the CPU) round differently on
    different x86-64 machines; a model built from the same input must be the same to the bit everywhere."""
    p, m = np.asarray(p, dtype=np.float64), np.asarray(m, dtype=np.float64)
    return p[..., 0, None] * m[0] + p[..., 1, None] * m[1] + p[..., 2, None] * m[2]


def dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products of 3-vectors (..., 3) in element-wise arithmetic (see :func:`rows_times`)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def norm(v: np.ndarray) -> np.ndarray:
    """Euclidean norms of vectors (..., k) over the last axis, in element-wise arithmetic (see :func:`rows_times`:
    numpy's norm of one vector is a BLAS dot product)."""
    v = np.asarray(v, dtype=np.float64)
    total = v[..., 0] * v[..., 0]
    for i in range(1, v.shape[-1]):
        total = total + v[..., i] * v[..., i]
    return np.sqrt(total)


def parallel_axis(inertia_origin: np.ndarray, mass: float, com: np.ndarray) -> np.ndarray:
    """Move an inertia tensor from the origin to the centre of mass: I_c = I_o - m (|c|^2 1 - c c^T)."""
    com = np.asarray(com, dtype=np.float64)
    return np.asarray(inertia_origin, dtype=np.float64) - mass * (dot3(com, com) * np.eye(3) - np.outer(com, com))


def principal_axes(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments [kg m^2] (3,) and quaternion (x, y, z, w) rotating the principal frame to the world.

    Raises InputError if the tensor is not symmetric positive definite or violates the triangle inequality.
    """
    inertia = np.asarray(inertia, dtype=np.float64)
    check_finite("inertia", inertia)
    if inertia.shape != (3, 3) or not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-14 * np.abs(inertia).max()):
        raise InputError(f"inertia must be a symmetric 3x3 tensor, got {inertia.tolist()}")
    moments, axes = symmetric_eigen(inertia[None])
    moments, axes = moments[0], axes[0]
    check_positive("inertia principal moments", moments)
    tol = 1e-9 * moments.max()
    if moments[0] + moments[1] < moments[2] - tol:
        raise InputError(f"inertia principal moments {moments.tolist()} violate I1 + I2 >= I3")
    return moments, matrix_to_quat(axes)


def principal_axes_many(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`principal_axes` of many tensors (c, 3, 3): principal moments [kg m^2] (c, 3), quaternions (c, 4)."""
    inertia = np.asarray(inertia, dtype=np.float64)
    check_finite("inertia", inertia)
    moments, axes = symmetric_eigen(inertia)
    check_positive("inertia principal moments", moments)
    bad = moments[:, 0] + moments[:, 1] < moments[:, 2] - 1e-9 * moments.max(axis=1)
    if bad.any():
        raise InputError(f"inertia principal moments {moments[bad][0].tolist()} violate I1 + I2 >= I3")
    return moments, matrices_to_quats(axes)


JACOBI_SWEEPS = 8
"""sweeps of :func:`symmetric_eigen`, always all of them: Jacobi's rotations converge quadratically, and a 3x3
tensor is diagonal to the last bit after four or five; a fixed count keeps a tensor's result independent of the
others computed with it."""


def symmetric_eigen(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and eigenvectors of many symmetric 3x3 matrices, by cyclic Jacobi rotations.

    Written with numpy's element-wise arithmetic only (no BLAS or LAPACK), so its bits are the same on every machine:
    LAPACK's ``eigh`` picks its kernels by the CPU and its last bits differ between x86-64 machines, and the
    principal axes' last bits reach every result with a body in it.

    Args:
        a: symmetric matrices (c, 3, 3) (only the upper triangle is read).

    Returns:
        (eigenvalues (c, 3), ascending; eigenvectors (c, 3, 3), column j for eigenvalue j, a right-handed frame:
        determinant +1).
    """
    a = np.array(a, dtype=np.float64).reshape(-1, 3, 3)
    d = [a[:, 0, 0].copy(), a[:, 1, 1].copy(), a[:, 2, 2].copy()]
    off = {(0, 1): a[:, 0, 1].copy(), (0, 2): a[:, 0, 2].copy(), (1, 2): a[:, 1, 2].copy()}
    v = np.zeros_like(a)
    v[:, 0, 0] = v[:, 1, 1] = v[:, 2, 2] = 1.0
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        for _ in range(JACOBI_SWEEPS):
            for p, q in ((0, 1), (0, 2), (1, 2)):
                r = 3 - p - q
                apq = off[(p, q)]
                # skip a rotation whose angle would not change the diagonal (Numerical Recipes' rule)
                small = (np.abs(apq) * 1e18 <= np.abs(d[p])) & (np.abs(apq) * 1e18 <= np.abs(d[q]))
                skip = small | (apq == 0.0)
                theta = np.where(skip, 0.0, (d[q] - d[p]) / np.where(skip, 1.0, 2.0 * apq))
                t = np.where(skip, 0.0, np.where(theta >= 0.0, 1.0, -1.0) / (np.abs(theta)
                                                                            + np.sqrt(theta * theta + 1.0)))
                t = np.where(np.isfinite(theta * theta), t, 0.5 / np.where(skip, 1.0, theta))  # huge theta: 1 / 2theta
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                d[p] = d[p] - t * apq
                d[q] = d[q] + t * apq
                arp, arq = off[tuple(sorted((r, p)))], off[tuple(sorted((r, q)))]
                off[tuple(sorted((r, p)))] = c * arp - s * arq
                off[tuple(sorted((r, q)))] = s * arp + c * arq
                off[(p, q)] = np.zeros_like(apq)
                vp, vq = v[:, :, p].copy(), v[:, :, q].copy()
                v[:, :, p] = c[:, None] * vp - s[:, None] * vq
                v[:, :, q] = s[:, None] * vp + c[:, None] * vq
    w = np.stack(d, axis=1)
    order = np.argsort(w, axis=1, kind="stable")
    w = np.take_along_axis(w, order, axis=1)
    v = np.take_along_axis(v, order[:, None, :], axis=2)
    det = (v[:, 0, 0] * (v[:, 1, 1] * v[:, 2, 2] - v[:, 1, 2] * v[:, 2, 1])
           - v[:, 0, 1] * (v[:, 1, 0] * v[:, 2, 2] - v[:, 1, 2] * v[:, 2, 0])
           + v[:, 0, 2] * (v[:, 1, 0] * v[:, 2, 1] - v[:, 1, 1] * v[:, 2, 0]))
    v[det < 0, :, 2] *= -1.0
    return w, v


def matrices_to_quats(m: np.ndarray) -> np.ndarray:
    """:func:`matrix_to_quat` of many rotation matrices (c, 3, 3): quaternions (x, y, z, w) (c, 4)."""
    m = np.asarray(m, dtype=np.float64)
    t = np.trace(m, axis1=1, axis2=2)
    q = np.empty((len(m), 4))
    d0, d1, d2 = m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]
    cases = [t > 0, (d0 > d1) & (d0 > d2), d1 > d2, np.ones(len(m), bool)]
    done = np.zeros(len(m), bool)
    for case, sel in enumerate(cases):
        i = np.flatnonzero(sel & ~done)
        done[i] = True
        a = m[i]
        if case == 0:
            s = 0.5 / np.sqrt(t[i] + 1.0)
            q[i] = np.stack([(a[:, 2, 1] - a[:, 1, 2]) * s, (a[:, 0, 2] - a[:, 2, 0]) * s,
                             (a[:, 1, 0] - a[:, 0, 1]) * s, 0.25 / s], axis=1)
        elif case == 1:
            s = 2.0 * np.sqrt(1.0 + a[:, 0, 0] - a[:, 1, 1] - a[:, 2, 2])
            q[i] = np.stack([0.25 * s, (a[:, 0, 1] + a[:, 1, 0]) / s, (a[:, 0, 2] + a[:, 2, 0]) / s,
                             (a[:, 2, 1] - a[:, 1, 2]) / s], axis=1)
        elif case == 2:
            s = 2.0 * np.sqrt(1.0 + a[:, 1, 1] - a[:, 0, 0] - a[:, 2, 2])
            q[i] = np.stack([(a[:, 0, 1] + a[:, 1, 0]) / s, 0.25 * s, (a[:, 1, 2] + a[:, 2, 1]) / s,
                             (a[:, 0, 2] - a[:, 2, 0]) / s], axis=1)
        else:
            s = 2.0 * np.sqrt(1.0 + a[:, 2, 2] - a[:, 0, 0] - a[:, 1, 1])
            q[i] = np.stack([(a[:, 0, 2] + a[:, 2, 0]) / s, (a[:, 1, 2] + a[:, 2, 1]) / s, 0.25 * s,
                             (a[:, 1, 0] - a[:, 0, 1]) / s], axis=1)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """Quaternion (x, y, z, w) of a proper rotation matrix (columns = rotated axes)."""
    m = np.asarray(m, dtype=np.float64)
    t = np.trace(m)
    if t > 0:
        s = 0.5 / np.sqrt(t + 1.0)
        q = [(m[2, 1] - m[1, 2]) * s, (m[0, 2] - m[2, 0]) * s, (m[1, 0] - m[0, 1]) * s, 0.25 / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    q = np.asarray(q)
    return q / norm(q)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a quaternion (x, y, z, w)."""
    x, y, z, w = np.asarray(q, dtype=np.float64) / norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quats_to_matrices(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of quaternions (n, 4) in (x, y, z, w) order."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=1,
    )


def check_faces(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validate a triangle mesh's arrays and return them as float64 (nv, 3) and int32 (nf, 3)."""
    vertices = check_points("mesh vertices", vertices)
    faces = np.asarray(faces)
    if faces.ndim != 2 or faces.shape[1] != 3 or faces.shape[0] == 0:
        raise InputError(f"mesh faces must have shape (n, 3) with n >= 1, got shape {faces.shape}")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InputError(f"mesh faces index vertices out of range [0, {len(vertices)}): {faces.min()}..{faces.max()}")
    return vertices, faces.astype(np.int32)
