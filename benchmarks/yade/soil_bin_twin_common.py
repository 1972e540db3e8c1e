"""Helpers shared by the soil-bin Yade twin (numpy only: imported by warpdem's Python AND by Yade's Python).

- :func:`yade_layout`: the Yade body ids every scene object of a spec gets (facets first, then the soil), so that
  both engines' contacts can be expressed in the same id space;
- :func:`incentre`: Yade's facet position (``utils.facet`` puts the body at the inscribed-circle centre);
- :func:`coordination`: every coordination number the twin reports, from a list of contacts in Yade's id space,
  computed by the same formulas for both engines (and checked against ``utils.avgNumInteractions`` in Yade).

Coordination numbers (C = number of contacts, "ss" = sphere-sphere, "sf" = sphere-facet):

- ``z_particle_ss`` = 2 C_ss / N_particles: warpdem's ``observers.coordination_number("soil")`` (a clump is one
  particle, every member-member contact between different particles counts);
- ``z_sphere_ss`` = 2 C_ss / N_spheres (each clump member a particle);
- ``z_yade_default`` = 2 (C_ss + C_sf) / len(O.bodies): Yade's ``utils.avgNumInteractions()`` with its defaults
  (every real interaction over every body: facets, spheres, clump members AND clump bodies);
- ``z_yade_clumps`` = Yade's ``utils.avgNumInteractions(considerClumps=True)``: a histogram over bodies inside the
  spheres' bounding box (``bodyNumInteractionsHistogram(aabbExtrema(0))``): each interaction adds one to each end
  whose position is strictly inside the box (a clump member's count goes to its clump); N counts every body with a
  count > 0 plus every non-member body inside the box with none (facets whose incentre lies inside the box count
  as particles!).
- ``z_particle_all`` = (2 C_ss + C_sf) / N_particles and ``z_sphere_all`` = (2 C_ss + C_sf) / N_spheres: the
  tests/reference convention (a sphere-facet contact counts once, for its sphere).
"""

from __future__ import annotations

import numpy as np


def incentre(tri: np.ndarray) -> np.ndarray:
    """Inscribed-circle centres of triangles (k, 3, 3) -> (k, 3) (Yade's Shop::inscribedCircleCenter)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    la = np.linalg.norm(b - c, axis=1)
    lb = np.linalg.norm(c - a, axis=1)
    lc = np.linalg.norm(a - b, axis=1)
    return (la[:, None] * a + lb[:, None] * b + lc[:, None] * c) / (la + lb + lc)[:, None]


def yade_layout(sphere_particle: np.ndarray, n_facets: int) -> dict[str, np.ndarray]:
    """Yade ids of a spec's bodies, in the order the twin script appends them: facets 0 .. n_facets-1 (bin, tool
    lower, tool upper), then the particles in the spec's (= warpdem's) order. A single sphere is one body; a clump
    (``O.bodies.appendClumped``) gets its k members' ids first, then its own.

    Returns sphere_id (n_spheres,) (the Yade id of each sphere, members included), particle_id (n_particles,)
    (the sphere itself or the clump body), is_clump (n_particles,), n_bodies, member_clump (n_bodies,) (clump id of
    each member body, -1 otherwise).
    """
    sphere_particle = np.asarray(sphere_particle)
    n_part = int(sphere_particle.max()) + 1
    counts = np.bincount(sphere_particle, minlength=n_part)
    sphere_id = np.empty(len(sphere_particle), np.int64)
    particle_id = np.empty(n_part, np.int64)
    nxt = n_facets
    first = np.r_[0, np.cumsum(counts)[:-1]]
    for p in range(n_part):
        k = counts[p]
        sphere_id[first[p]:first[p] + k] = np.arange(nxt, nxt + k)
        nxt += k
        if k == 1:
            particle_id[p] = nxt - 1
        else:
            particle_id[p] = nxt
            nxt += 1
    member_clump = np.full(nxt, -1, np.int64)
    is_clump = counts > 1
    member_clump[sphere_id] = np.where(is_clump[sphere_particle], particle_id[sphere_particle], -1)
    return {"sphere_id": sphere_id, "particle_id": particle_id, "is_clump": is_clump, "n_bodies": np.int64(nxt),
            "member_clump": member_clump}


def coordination(id1: np.ndarray, id2: np.ndarray, body_pos: np.ndarray, layout: dict[str, np.ndarray],
                 sphere_radius: np.ndarray, n_facets: int) -> dict[str, float]:
    """All coordination numbers of the module docstring from the real contacts (id1, id2) in Yade's id space
    (facet ids < n_facets) and the positions of every body (n_bodies, 3) (Yade's state.pos: facets at their
    incentre, clumps at their centre of mass, members at their own centre)."""
    id1 = np.asarray(id1, np.int64)
    id2 = np.asarray(id2, np.int64)
    nb = int(layout["n_bodies"])
    is_facet1, is_facet2 = id1 < n_facets, id2 < n_facets
    sf = is_facet1 ^ is_facet2
    ss = ~is_facet1 & ~is_facet2
    c_ss, c_sf = int(ss.sum()), int(sf.sum())
    n_part = len(layout["particle_id"])
    n_sph = len(layout["sphere_id"])
    out = {
        "c_ss": c_ss, "c_sf": c_sf,
        "z_particle_ss": 2.0 * c_ss / n_part,
        "z_sphere_ss": 2.0 * c_ss / n_sph,
        "z_particle_all": (2.0 * c_ss + c_sf) / n_part,
        "z_sphere_all": (2.0 * c_ss + c_sf) / n_sph,
        "z_yade_default": 2.0 * (c_ss + c_sf) / nb,
    }
    # considerClumps=True: bodyNumInteractionsHistogram(aabbExtrema(0))
    sid = layout["sphere_id"]
    lo = (body_pos[sid] - sphere_radius[:, None]).min(axis=0)
    hi = (body_pos[sid] + sphere_radius[:, None]).max(axis=0)
    inside = np.all((body_pos > lo) & (body_pos < hi), axis=1)
    member = layout["member_clump"]
    counts = np.zeros(nb, np.int64)
    for ids in (id1, id2):
        ok = inside[ids]
        target = np.where(member[ids] >= 0, member[ids], ids)
        np.add.at(counts, target[ok], 1)
    n = int(np.count_nonzero(counts > 0) + np.count_nonzero((counts == 0) & inside & (member < 0)))
    out["z_yade_clumps"] = float(counts.sum()) / n if n else float("nan")
    out["yade_clumps_n"] = n
    return out


def closest_point_triangle(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, int]:
    """Closest point of triangle abc to p and its feature (0 face interior, 1 edge, 2 vertex): Ericson's
    algorithm, as warpdem's ``geometry.closest_point_triangle``."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = ab @ ap, ac @ ap
    if d1 <= 0 and d2 <= 0:
        return a.copy(), 2
    bp = p - b
    d3, d4 = ab @ bp, ac @ bp
    if d3 >= 0 and d4 <= d3:
        return b.copy(), 2
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        return a + d1 / (d1 - d3) * ab, 1
    cp = p - c
    d5, d6 = ab @ cp, ac @ cp
    if d6 >= 0 and d5 <= d6:
        return c.copy(), 2
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        return a + d2 / (d2 - d6) * ac, 1
    va = d3 * d6 - d5 * d4
    if va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
        return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b), 1
    den = 1.0 / (va + vb + vc)
    return a + ab * (vb * den) + ac * (vc * den), 0


def warpdem_suppressed(centre: np.ndarray, radius: float, tris: np.ndarray) -> np.ndarray:
    """Which of a sphere's contacts with the triangles ``tris`` (k, 3, 3) of ONE mesh warpdem drops (its rule in
    ``warpdem.contacts.suppressed``; every triangle given is touching): an edge or vertex contact whose closest point
    lies on another touching triangle's face contact, or that coincides with an earlier contact's point (tolerance
    1e-5 R). Returns (k,) bool."""
    geo = [closest_point_triangle(centre, t[0], t[1], t[2]) for t in tris]
    tol = 1e-5 * radius
    out = np.zeros(len(tris), bool)
    for k, (pt, feat) in enumerate(geo):
        if feat == 0:
            continue
        for k2, (pt2, feat2) in enumerate(geo):
            if k2 == k:
                continue
            if feat2 == 0:
                t = tris[k2]
                q, _ = closest_point_triangle(pt, t[0], t[1], t[2])
                if np.linalg.norm(q - pt) <= tol:
                    out[k] = True
                    break
            elif k2 < k and np.linalg.norm(pt2 - pt) <= tol:
                out[k] = True
                break
    return out
