"""Broad phase: candidate lists (with a neighbour skin) for sphere-sphere and sphere-triangle contacts.

A candidate list is stored CSR-style per sphere (``start``, ``count``, then one entry per candidate); every entry
carries its contact history (:class:`~warpdem.laws.Hist`), so contacts persist across rebuilds: a rebuild
makes the new lists in scratch arrays, copies each surviving pair's history from the old lists, and copies the
result back (fixed array addresses, so the whole step can live in one CUDA graph).

Sphere-sphere candidates come from a grouped float64 ``wp.HashGrid`` (group = world, so worlds never meet);
sphere-triangle candidates from ``wp.mesh_query_aabb`` against each mesh in its own body frame (no refit needed).
A pair is a candidate when its gap is below the skin; contacts that exist stay listed however far they stretch.
The lists are rebuilt when the largest sphere displacement since the last build plus the larger of that and the
largest mesh displacement exceeds the skin, so no contact can be missed between two builds (the spheres' displacement
is measured where their positions are updated, integrator.update_spheres_kernel; the meshes' here).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import warp as wp

from . import cpu_threads
from . import kernel_args as ka
from .geometry import closest_point_triangle
from .kernel_args import BodyState, Meshes, SphereList, Spheres, TriangleList
from .laws import ACTIVE, Hist, empty_hist

wp.set_module_options({"enable_backward": False})


# ----------------------------------------------------------------------------- displacement check
@wp.func
def mesh_displacement(
    m: int,
    # Model:
    mesh_body: wp.array(dtype=int),
    mesh_rmax: wp.array(dtype=float),
    # Data in:
    body_pos_in: wp.array(dtype=wp.vec3d),
    body_quat_in: wp.array(dtype=wp.quatd),
    build_pos_in: wp.array(dtype=wp.vec3d),
    build_quat_in: wp.array(dtype=wp.quatd),
) -> float:
    """How far [m] any point of mesh instance m may have moved since the last list build: its body's translation
    plus the rotation angle times the mesh's largest vertex distance from the body's centre of mass."""
    b = mesh_body[m]
    dq = body_quat_in[b] * wp.quat_inverse(build_quat_in[m])
    s = wp.min(wp.length(wp.vec3d(dq[0], dq[1], dq[2])), wp.float64(1.0))
    angle = 2.0 * float(wp.asin(s))
    return float(wp.length(body_pos_in[b] - build_pos_in[m])) + angle * mesh_rmax[m]


@wp.kernel
def _record_mesh_build_pose_kernel(meshes: Meshes, state: BodyState, build_pos_out: wp.array(dtype=wp.vec3d),
                                   build_quat_out: wp.array(dtype=wp.quatd)):
    """The pose of mesh instance m's body at a list build (position [m], orientation), for the displacement check."""
    m = wp.tid()
    build_pos_out[m] = state.pos[meshes.body[m]]
    build_quat_out[m] = state.quat[meshes.body[m]]


@wp.kernel
def allocate_blocks_kernel(grid: wp.uint64, count: wp.array(dtype=int), total: wp.array(dtype=int),
                           start_out: wp.array(dtype=int)):
    """Give each sphere a contiguous block of its ``count`` entries (an exclusive scan on the CPU, where threads
    run in order; on CUDA the blocks' order varies but each sphere's entries stay sorted). Unlike
    ``wp.utils.array_scan`` it allocates nothing, so it can run inside a conditional CUDA graph node.

    ``grid`` (not 0): thread t takes the grid's t-th sphere in cell order, so that the blocks lie roughly in the
    cells' order and a thread per list entry reads spheres near its neighbours' (on CUDA, where the order of the
    blocks is free anyway); 0: thread t takes sphere t (the CPU's threads cut the lists by sphere ranges)."""
    i = wp.tid()
    if grid != wp.uint64(0):
        i = wp.hash_grid_point_id(grid, i)
    start_out[i] = wp.atomic_add(total, 0, count[i])


@wp.func
def _list_block(fill: int, i: int, capacity: int, start: wp.array(dtype=int), count: wp.array(dtype=int),
                overflow_out: wp.array(dtype=int)):
    """Sphere i's block of a candidate list being built: returns (first entry, most entries): (0, unbounded) while
    counting (fill = 0); while filling, its start and count, the count cut to the list's capacity (entries) where
    the block would pass it (count[i] then holds the cut count and overflow_out[0] the entries needed)."""
    base = int(0)
    n = int(2147483647)
    if fill == 1:
        base = start[i]
        n = count[i]
        if base + n > capacity:
            wp.atomic_max(overflow_out, 0, base + n)
            n = wp.max(capacity - base, 0)
            count[i] = n
    return base, n


# ----------------------------------------------------------------------------- sphere-sphere lists
@wp.func
def _ss_is_candidate(
    i: int, j: int, sphere_pos: wp.array(dtype=wp.vec3d), radius: wp.array(dtype=wp.float64), skin: float
) -> int:
    d = wp.length(sphere_pos[j] - sphere_pos[i])
    if d < radius[i] + radius[j] + wp.float64(skin):
        return 1
    return 0


@wp.kernel
def _ss_build_kernel(
    first: int,  # the first sphere of this launch (a CPU thread's share)
    grid: wp.uint64,
    spheres: Spheres,
    max_radius: float,
    skin: float,
    fill: int,
    sphere_pos: wp.array(dtype=wp.vec3d),
    old: SphereList,
    built: SphereList,  # fill = 0: out: count; fill = 1: in: start; in/out: count; out: other, hist
    overflow_out: wp.array(dtype=int),
):
    """Count (fill = 0) or fill (fill = 1) the sphere-sphere candidates of sphere i: the spheres of other bodies of
    its world with a higher index within the skin [m], and its existing contacts stretched beyond the skin (they
    stay listed). Filling sorts them by partner and carries the old list's history over.

    Thread t takes the grid's t-th sphere in cell order (``hash_grid_point_id``), not sphere t: neighbouring threads
    then query neighbouring cells and read the same spheres, whatever the spheres' own order. A sphere's entries do
    not depend on which thread builds them."""
    i = wp.hash_grid_point_id(grid, wp.tid() + first)
    radius = spheres.radius
    other_out = built.other
    old_other = old.other
    base, n = _list_block(fill, i, built.other.shape[0], built.start, built.count, overflow_out)
    x = sphere_pos[i]
    query = wp.hash_grid_query(grid, x, radius[i] + wp.float64(max_radius + skin), spheres.world[i])
    j = int(0)
    c = int(0)
    while wp.hash_grid_query_next(query, j):
        if j > i and spheres.body[j] != spheres.body[i] and c < n:
            if _ss_is_candidate(i, j, sphere_pos, radius, skin) == 1:
                if fill == 1:
                    other_out[base + c] = j
                c += 1
    for k in range(old.start[i], old.start[i] + old.count[i]):
        jj = old_other[k]
        if (old.hist[k].flags & ACTIVE) != 0 and _ss_is_candidate(i, jj, sphere_pos, radius, skin) == 0 and c < n:
            if fill == 1:
                other_out[base + c] = jj
            c += 1
    if fill == 0:
        built.count[i] = c
        return
    # sort by partner index: the order of force sums then does not depend on the hash grid's internals
    for a in range(1, n):
        v = other_out[base + a]
        b = a - 1
        while b >= 0 and other_out[base + b] > v:
            other_out[base + b + 1] = other_out[base + b]
            b -= 1
        other_out[base + b + 1] = v
    # inherit history from the old list (both are sorted by partner)
    ko = old.start[i]
    ko_end = ko + old.count[i]
    for a in range(n):
        jj = other_out[base + a]
        while ko < ko_end and old_other[ko] < jj:
            ko += 1
        if ko < ko_end and old_other[ko] == jj:
            built.hist[base + a] = old.hist[ko]
        else:
            built.hist[base + a] = empty_hist()


# ----------------------------------------------------------------------------- sphere-triangle lists
@wp.func
def sphere_in_body_frame(x: wp.vec3d, body_pos: wp.vec3d, body_quat: wp.quatd) -> wp.vec3d:
    """A world point expressed in a body's principal frame [m]."""
    return wp.quat_rotate_inv(body_quat, x - body_pos)


@wp.func
def triangle_distance(p: wp.vec3d, tri_vertices: wp.array(dtype=wp.vec3d), t: int) -> float:
    """Distance [m] from p to triangle t (both in the mesh body's frame)."""
    cp = closest_point_triangle(p, tri_vertices[3 * t], tri_vertices[3 * t + 1], tri_vertices[3 * t + 2])
    return float(wp.length(p - wp.vec3d(cp[0], cp[1], cp[2])))


@wp.func
def _st_is_candidate(
    i: int,
    m: int,
    f: int,
    sphere_pos: wp.array(dtype=wp.vec3d),
    radius: wp.array(dtype=wp.float64),
    mesh_body: wp.array(dtype=int),
    mesh_tri_offset: wp.array(dtype=int),
    tri_vertices: wp.array(dtype=wp.vec3d),
    body_pos: wp.array(dtype=wp.vec3d),
    body_quat: wp.array(dtype=wp.quatd),
    skin: float,
) -> int:
    b = mesh_body[m]
    p = sphere_in_body_frame(sphere_pos[i], body_pos[b], body_quat[b])
    if triangle_distance(p, tri_vertices, mesh_tri_offset[m] + f) < float(radius[i]) + skin:
        return 1
    return 0


@wp.kernel
def _st_build_kernel(
    first: int,  # the first sphere of this launch (a CPU thread's share)
    spheres: Spheres,
    meshes: Meshes,
    skin: float,
    fill: int,
    sphere_pos: wp.array(dtype=wp.vec3d),
    state: BodyState,
    old: TriangleList,
    built: TriangleList,  # fill = 0: out: count; fill = 1: in: start; in/out: count; out: mesh, face, hist
    overflow_out: wp.array(dtype=int),
):
    """Count (fill = 0) or fill (fill = 1) the sphere-triangle candidates of sphere i."""
    radius = spheres.radius
    mesh_body = meshes.body
    mesh_tri_offset = meshes.tri_offset
    tri_vertices = meshes.tri_vertices
    body_pos = state.pos
    body_quat = state.quat
    mesh_out = built.mesh
    face_out = built.face
    old_mesh = old.mesh
    old_face = old.face
    old_start = old.start
    old_count = old.count
    old_hist = old.hist
    i = wp.tid() + first
    base, n = _list_block(fill, i, built.mesh.shape[0], built.start, built.count, overflow_out)
    c = int(0)
    r = float(radius[i]) + skin
    m0 = meshes.world_start[spheres.world[i]]
    for m in range(m0, m0 + meshes.per_world):
        b = mesh_body[m]
        if b == spheres.body[i]:
            continue
        p = sphere_in_body_frame(sphere_pos[i], body_pos[b], body_quat[b])
        pf = wp.vec3f(p)
        query = wp.mesh_query_aabb(meshes.ids[m], pf - wp.vec3f(r), pf + wp.vec3f(r))
        f = int(0)
        while wp.mesh_query_aabb_next(query, f):
            if triangle_distance(p, tri_vertices, mesh_tri_offset[m] + f) < r and c < n:
                if fill == 1:
                    mesh_out[base + c] = m
                    face_out[base + c] = f
                c += 1
    for k in range(old_start[i], old_start[i] + old_count[i]):
        if (old_hist[k].flags & ACTIVE) != 0 and c < n:
            mk = old_mesh[k]
            if _st_is_candidate(
                i, mk, old_face[k], sphere_pos, radius, mesh_body, mesh_tri_offset, tri_vertices, body_pos,
                body_quat, skin
            ) == 0:
                if fill == 1:
                    mesh_out[base + c] = mk
                    face_out[base + c] = old_face[k]
                c += 1
    if fill == 0:
        built.count[i] = c
        return
    # sort by (mesh, face), then inherit history
    for a in range(1, n):
        vm = mesh_out[base + a]
        vf = face_out[base + a]
        bb = a - 1
        while bb >= 0 and (mesh_out[base + bb] > vm or (mesh_out[base + bb] == vm and face_out[base + bb] > vf)):
            mesh_out[base + bb + 1] = mesh_out[base + bb]
            face_out[base + bb + 1] = face_out[base + bb]
            bb -= 1
        mesh_out[base + bb + 1] = vm
        face_out[base + bb + 1] = vf
    for a in range(n):
        built.hist[base + a] = empty_hist()
        for k in range(old_start[i], old_start[i] + old_count[i]):
            if old_mesh[k] == mesh_out[base + a] and old_face[k] == face_out[base + a]:
                built.hist[base + a] = old_hist[k]


@wp.kernel
def _list_total_kernel(alloc_total: wp.array(dtype=int), slot: int, out: wp.array(dtype=int)):
    """Record the entries a list needed at its last build (list_stats[slot]), for capacity monitoring."""
    wp.atomic_max(out, slot, alloc_total[slot])


# ----------------------------------------------------------------------------- the build
def build(grid: wp.HashGrid, cell: float, skin: float, model: object, state: object, data: object,
          contacts: object, parts: Sequence[tuple[int, int]] | None = None) -> None:
    """Rebuild both candidate lists of ``contacts`` (types.Contacts) from the current sphere positions of ``data``
    (warpdem.data.Data) and body positions of ``state``.

    The new lists are made in the scratch lists (``ss_new``, ``st_new``), each surviving pair's history is copied
    from the old lists, and the result is copied back, so the arrays keep their addresses (capturable on CUDA).
    ``list_stats`` records the entries each list needed and, on overflow, the capacity it lacked (the caller grows
    the lists and builds again). ``grid``: the hash grid (cell size ``cell`` [m]); ``skin`` [m]: the candidate gap.
    ``parts``: on the CPU, sphere ranges (first, end) whose per-sphere kernels run at once on CPU threads
    (cpu_threads.Parallel); default: all spheres in one launch.
    """
    m, d, c, dev = model, data, contacts, model.device
    ns = m.n_spheres
    if ns == 0:
        return
    parts = list(parts) if parts else [(0, ns)]

    def per_sphere(kernel: object, inputs: list, outputs: list) -> None:
        """``kernel`` over every sphere, its first argument the range's first sphere."""
        if len(parts) == 1:
            wp.launch(kernel, ns, inputs=[0, *inputs], outputs=outputs, device=dev)
            return
        cpu_threads.Parallel(kernel.key, [
            [wp.launch(kernel, end - first, inputs=[first, *inputs], outputs=outputs, device=dev,
                       record_cmd=True).launch]
            for first, end in parts if end > first
        ])()

    grid.build(d.sphere_pos, cell, groups=m.sphere_world)
    spheres = ka.spheres_of(m)
    ss_in = [d.sphere_pos, ka.sphere_list_of(c.ss)]
    ss_out = [ka.sphere_list_of(c.ss_new), c.list_stats[2:3]]
    per_sphere(_ss_build_kernel, [grid.id, spheres, m.max_radius, skin, 0, *ss_in], ss_out)
    c.alloc_total.zero_()
    order = wp.uint64(0) if dev.is_cpu else grid.id  # the blocks in the cells' order on CUDA
    wp.launch(allocate_blocks_kernel, ns, inputs=[order, c.ss_new.count, c.alloc_total[0:1]],
              outputs=[c.ss_new.start], device=dev)
    per_sphere(_ss_build_kernel, [grid.id, spheres, m.max_radius, skin, 1, *ss_in], ss_out)
    wp.launch(_list_total_kernel, 1, inputs=[c.alloc_total, 0, c.list_stats], device=dev)
    c.ss.copy_from(c.ss_new)
    c.ss.index_owners()
    wp.copy(c.build_pos, d.sphere_pos)
    if m.n_meshes == 0:
        return
    meshes = ka.meshes_of(m, d)
    bodies = ka.body_state_of(state)
    st_in = [d.sphere_pos, bodies, ka.triangle_list_of(c.st)]
    st_out = [ka.triangle_list_of(c.st_new), c.list_stats[3:4]]
    per_sphere(_st_build_kernel, [spheres, meshes, skin, 0, *st_in], st_out)
    wp.launch(allocate_blocks_kernel, ns, inputs=[order, c.st_new.count, c.alloc_total[1:2]],
              outputs=[c.st_new.start], device=dev)
    per_sphere(_st_build_kernel, [spheres, meshes, skin, 1, *st_in], st_out)
    wp.launch(_list_total_kernel, 1, inputs=[c.alloc_total, 1, c.list_stats], device=dev)
    c.st.copy_from(c.st_new)
    wp.launch(_record_mesh_build_pose_kernel, m.n_meshes, inputs=[meshes, bodies],
              outputs=[c.mesh_build_pos, c.mesh_build_quat], device=dev)


@wp.kernel
def _owner_kernel(start: wp.array(dtype=int), count: wp.array(dtype=int), owner_out: wp.array(dtype=int)):
    """owner_out[k] = i for every entry k of sphere i's block (free slots keep their -1); entries past the end of
    owner_out (lists not yet replaced after a shrinking growth) are left out."""
    i = wp.tid()
    for k in range(start[i], wp.min(start[i] + count[i], owner_out.shape[0])):
        owner_out[k] = i


# ----------------------------------------------------------------------------- host-side container
class PairList:
    """CSR candidate list with per-entry contact history (sphere-sphere: ``other``; sphere-triangle: ``mesh``,
    ``face``). ``start``/``count`` have shape (n_spheres,); entry arrays have shape (capacity,); ``owner``
    (capacity,), each entry's sphere, only where :meth:`enable_owners` asked for it (else None)."""

    def __init__(self, n_spheres: int, capacity: int, device: wp.context.Device, two_keys: bool) -> None:
        self.device = device
        self.two_keys = two_keys
        self.capacity = int(max(capacity, 16))
        self.start = wp.zeros(n_spheres, dtype=int, device=device)
        self.count = wp.zeros(n_spheres, dtype=int, device=device)
        self.key_a = wp.zeros(self.capacity, dtype=int, device=device)
        self.key_b = wp.zeros(self.capacity if two_keys else 1, dtype=int, device=device)
        self.hist = wp.zeros(self.capacity, dtype=Hist, device=device)
        self.owner: wp.array | None = None  # see enable_owners

    @property
    def other(self) -> wp.array:
        """a sphere-sphere list's partner sphere of each entry, int32 (capacity,) (``key_a``)."""
        return self.key_a

    @property
    def mesh(self) -> wp.array:
        """a sphere-triangle list's mesh instance of each entry, int32 (capacity,) (``key_a``)."""
        return self.key_a

    @property
    def face(self) -> wp.array:
        """a sphere-triangle list's triangle of each entry within its mesh's geometry, int32 (capacity,)
        (``key_b``)."""
        return self.key_b

    def enable_owners(self) -> None:
        """Keep ``owner`` (capacity,): each entry's sphere, -1 for a free slot (contacts.sphere_pair_kernel's
        thread per entry); :meth:`index_owners` fills it from start and count."""
        if self.owner is None:
            self.owner = wp.full(self.capacity, -1, dtype=int, device=self.device)
            self.index_owners()

    def index_owners(self) -> None:
        """Fill ``owner`` from start and count (after a build, a growth or a checkpoint's lists); no-op without it."""
        if self.owner is None:
            return
        self.owner.fill_(-1)
        wp.launch(_owner_kernel, self.start.shape[0], inputs=[self.start, self.count], outputs=[self.owner],
                  device=self.device)

    def grow(self, capacity: int) -> None:
        """Reallocate the entry arrays with another capacity (larger, or any when a checkpoint's lists replace
        them next), keeping the entries that fit."""
        capacity = int(capacity)
        for name in ("key_a", "key_b", "hist"):
            if name == "key_b" and not self.two_keys:
                continue
            old = getattr(self, name)
            new = wp.zeros(capacity, dtype=old.dtype, device=self.device)
            wp.copy(new, old, count=min(old.shape[0], capacity))
            setattr(self, name, new)
        self.capacity = capacity
        if self.owner is not None:
            self.owner = wp.full(capacity, -1, dtype=int, device=self.device)
            self.index_owners()

    def copy_from(self, other: PairList) -> None:
        """Copy start, count and all entries (same capacities); not ``owner``: :meth:`index_owners` after."""
        wp.copy(self.start, other.start)
        wp.copy(self.count, other.count)
        wp.copy(self.key_a, other.key_a)
        if self.two_keys:
            wp.copy(self.key_b, other.key_b)
        wp.copy(self.hist, other.hist)

    def numpy(self) -> dict[str, np.ndarray]:
        """Host copies: start, count, keys and the history fields."""
        out = {"start": self.start.numpy(), "count": self.count.numpy(), "key_a": self.key_a.numpy()}
        if self.two_keys:
            out["key_b"] = self.key_b.numpy()
        out["hist"] = self.hist.numpy()
        return out
