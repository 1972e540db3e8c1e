"""Physics against closed-form references (CPU). Each test states its reference equation and tolerance."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEVICE, square

import warpdem as wd
from warpdem import observers as obs

R = 0.01
RHO = 2700.0
E = 1e7
MASS = RHO * 4.0 / 3.0 * np.pi * R**3


def soil(**kw: object) -> wd.Material:
    base = dict(young=E, poisson=0.3, density=RHO, friction_angle=30.0)
    base.update(kw)
    return wd.Material(**base)


def test_two_sphere_normal_impact() -> None:
    # Reference: linear spring between equal spheres, kn = E R (Yade: 2 E1R1 E2R2/(E1R1 + E2R2)); reduced mass
    # m* = m/2; contact lasts t_c = pi sqrt(m*/kn); without damping the rebound is elastic (velocities swap).
    # Tolerance: the contact is resolved to one step (dt = t_c/700) and leapfrog's energy error is O(dt^2).
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("m", soil())
    v0 = 0.1
    b.add_sphere((0, 0, 0), R, "m", velocity=(v0, 0, 0))
    b.add_sphere((2 * R + 1e-5, 0, 0), R, "m", velocity=(-v0, 0, 0))
    model, state = b.finalize(DEVICE)
    dt = 1e-6
    sim = wd.Simulation(model, state, dt=dt)
    forces = []
    for _ in range(1000):
        sim.step()
        forces.append(sim.data.body_force.numpy()[1, 0])
    forces = np.asarray(forces)
    t_c = np.pi * np.sqrt(0.5 * MASS / (E * R))
    duration = np.count_nonzero(forces > 0) * dt
    assert duration == pytest.approx(t_c, abs=2 * dt)
    v = state.body_vel.numpy()[:, 0]
    assert v[0] == pytest.approx(-v0, rel=1e-4)
    assert v[1] == pytest.approx(v0, rel=1e-4)


def test_free_fall_matches_leapfrog_closed_form() -> None:
    # Reference: with constant g, v_n = v0 + n dt g and x_n = x0 + n dt v0 + dt^2 g n(n+1)/2 (leapfrog with the
    # velocity at the half step), which tends to x0 + v0 t + g t^2/2. Tolerance: float64 round-off.
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_material("m", soil())
    b.add_sphere((0.3, -0.2, 1.0), R, "m", velocity=(0.5, 0, 2.0))
    model, state = b.finalize(DEVICE)
    dt, n = 1e-4, 500
    sim = wd.Simulation(model, state, dt=dt)
    sim.advance(n)
    x = state.body_pos.numpy()[0]
    expected = np.array([0.3 + n * dt * 0.5, -0.2, 1.0 + n * dt * 2.0 - 9.81 * dt**2 * n * (n + 1) / 2])
    np.testing.assert_allclose(x, expected, rtol=0, atol=1e-12)
    assert abs(x[2] - (1.0 + 2.0 * n * dt - 0.5 * 9.81 * (n * dt) ** 2)) < 9.81 * dt * n * dt


def incline_run(theta: float, phi: float, steps: int = 4000) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """A sphere with blocked rotation released on a two-triangle incline of angle theta [deg]."""
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_material("s", soil(friction_angle=phi))
    b.add_material("w", soil(friction_angle=60.0))
    v, f = square((0, 0, 0), 0.5, theta)
    b.add_mesh("plane", v, f, "w")
    t = np.radians(theta)
    normal = np.array([np.sin(t), 0.0, np.cos(t)])
    kn = 4.0 / 3.0 * E * R  # facet-sphere: R1 = 2R, R2 = R
    overlap = MASS * 9.81 * np.cos(t) / kn
    start = np.array([0.2, -0.2, 0.0]) @ np.eye(3) + (R - overlap) * normal  # away from the diagonal
    start[2] = -np.tan(t) * start[0] + (R - overlap) / np.cos(t)
    b.add_sphere(start, R, "s", blocked="XYZ")
    model, state = b.finalize(DEVICE)
    dt = 2e-5
    sim = wd.Simulation(model, state, dt=dt)
    x0 = state.body_pos.numpy()[1].copy()
    sim.advance(steps // 2)
    half = state.body_pos.numpy()[1] - x0
    v_half = state.body_vel.numpy()[1].copy()
    sim.advance(steps - steps // 2)
    dv = state.body_vel.numpy()[1] - v_half
    return half, state.body_pos.numpy()[1] - x0, dv, (steps - steps // 2) * dt


def test_sliding_threshold_on_inclined_facet() -> None:
    # Reference: a block on an incline slides iff tan(theta) > tan(phi) (phi = min of the two materials' angles);
    # when it slides, a = g (sin(theta) - cos(theta) tan(phi)) along the slope.
    # The shear spring starts unloaded, so the first ~30 steps accelerate almost freely (Yade does the same): the
    # acceleration is measured over the second half of the run. Below the threshold the undamped shear spring
    # overshoots to twice the static shear force and slips a little in the first oscillations; it must then stop:
    # "sticks" means less than 0.1 um of motion over the second half. Tolerance on a: 0.2 % (float32 forces).
    phi = 25.0
    half, d_stick, _, _ = incline_run(phi - 1.0, phi)
    assert np.linalg.norm(d_stick - half) < 1e-7
    theta = phi + 5.0
    _, d_slide, dv, t = incline_run(theta, phi)
    th, ph = np.radians(theta), np.radians(phi)
    a = 9.81 * (np.sin(th) - np.cos(th) * np.tan(ph))
    assert np.linalg.norm(dv) / t == pytest.approx(a, rel=2e-3)
    assert d_slide[0] > 0 and d_slide[2] < 0  # down the slope


def pulled_pair(fragile: bool, steps: int, bonds: list | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Sphere 2 pulled away from a fixed sphere 1 at 0.01 m/s after cohesion is set; returns (un, Fn) per step
    (and appends the cohesive_bonds observer's count after each step to ``bonds``)."""
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("c", soil(normal_cohesion=2e4, shear_cohesion=1e4, fragile=fragile))
    b.add_sphere((0, 0, 0), R, "c", blocked="xyzXYZ")
    b.add_sphere((2 * R - 1e-5, 0, 0), R, "c", blocked="xyzXYZ", velocity=(0.01, 0, 0))
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=1e-6, unp_max=-1.0)
    sim.set_cohesion_now()
    un, fn = [], []
    count = wd.observers.cohesive_bonds("default")
    for _ in range(steps):
        gap = state.body_pos.numpy()[1, 0] - state.body_pos.numpy()[0, 0]
        sim.step()
        un.append(2 * R - gap)
        fn.append(-sim.data.body_force.numpy()[0, 0])  # force on sphere 1 is -Fn n
        if bonds is not None:
            bonds.append(float(count(sim)[0]))
    return np.asarray(un), np.asarray(fn)


def test_cohesive_pair_breaks_at_normal_adhesion() -> None:
    # Reference: a_n = C_n min(R1, R2)^2 = 2e4 * 1e-4 = 2 N (Yade, no pi); kn = E R = 1e5 N/m, so a fragile bond
    # breaks when kn un < -a_n, i.e. at un = -2e-5 m, and carries no force after. Non-fragile: the tension stays at
    # -a_n (perfect plasticity). Tolerance: one step of pulling, v dt kn = 1e-3 N.
    # The bond counter (observers.cohesive_bonds) reads one bond until the step it breaks and none after; a
    # non-fragile bond that yields stays a bond.
    an = 2e4 * R**2
    bonds: list[float] = []
    un, fn = pulled_pair(True, 4000, bonds)
    assert fn.min() == pytest.approx(-an, abs=1.1e-3)
    broke = np.argmax(fn == 0.0)
    assert un[broke] == pytest.approx(-an / (E * R), abs=1.1e-8)
    assert np.all(fn[broke:] == 0.0)
    np.testing.assert_array_equal(bonds, np.where(np.arange(len(bonds)) < broke, 1.0, 0.0))
    bonds = []
    un, fn = pulled_pair(False, 4000, bonds)
    plastic = un < -an / (E * R) - 1e-8
    assert plastic.sum() > 900
    np.testing.assert_allclose(fn[plastic], -an, rtol=1e-5)
    assert set(bonds) == {1.0}


def test_rolling_resistance_threshold() -> None:
    # Reference (incremental moment law): a sphere rolled at angular velocity w against a fixed one at constant
    # overlap builds M = kr w t (kr = R1 R2 ks alpha_r, ks = nu kn, alpha_r = 2) until |M| = eta_roll R |Fn|, where
    # it stays. Tolerance: float32 accumulation, 1e-4 relative.
    eta = 0.3
    mat = soil(moment_law=True, eta_roll=eta, eta_twist=eta)
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("r", mat)
    b.add_sphere((0, 0, 0), R, "r", blocked="xyzXYZ")
    overlap = 1e-5
    w = 0.5
    b.add_sphere((2 * R - overlap, 0, 0), R, "r", blocked="xyzXYZ", angular_velocity=(0, 0, w))
    model, state = b.finalize(DEVICE)
    dt = 1e-6
    sim = wd.Simulation(model, state, dt=dt, always_use_moment_law=True)
    kn = E * R
    kr = R * R * 0.3 * kn * 2.0
    fn = kn * overlap
    m_cap = eta * R * fn
    moments = []
    for _ in range(3000):
        sim.step()
        moments.append(sim.contacts.ss.hist.numpy()[0]["mb"][2])
    moments = np.asarray(moments)
    steps = np.arange(1, len(moments) + 1)
    elastic = kr * w * dt * steps < 0.9 * m_cap
    np.testing.assert_allclose(moments[elastic], -kr * w * dt * steps[elastic], rtol=1e-4)
    assert np.abs(moments[-500:]).max() == pytest.approx(m_cap, rel=1e-4)
    # Yade applies the moment law to non-cohesive contacts only with always_use_moment_law
    b2 = wd.Simulation(*b.finalize(DEVICE), dt=dt)
    b2.advance(100)
    assert np.all(b2.contacts.ss.hist.numpy()[0]["mb"] == 0.0)


def test_clump_inertia_matches_trimesh() -> None:
    # Reference: trimesh's volume integrals over the members' (icosphere) surfaces, concatenated, which add up like
    # Yade's rule (overlaps counted twice). Tolerance: icosphere (subdivision 5) volume error, ~0.1 %.
    import trimesh

    from warpdem.mass import clump_mass, quat_to_matrix

    centres = np.array([[0.0, 0.0, 0.0], [0.014, 0.0, 0.004], [-0.006, 0.012, 0.0]])
    radii = np.array([0.010, 0.008, 0.012])
    mesh = trimesh.util.concatenate(
        [
            trimesh.creation.icosphere(subdivisions=5, radius=r).apply_translation(c)
            for c, r in zip(centres, radii, strict=True)
        ]
    )
    mesh.density = RHO
    m, com, inertia = clump_mass(centres, radii, np.full(3, RHO))
    assert m == pytest.approx(mesh.mass, rel=2e-3)
    np.testing.assert_allclose(com, mesh.center_mass, atol=1e-5)
    np.testing.assert_allclose(inertia, mesh.moment_inertia, rtol=0, atol=4e-3 * np.abs(inertia).max())
    # and the builder's principal frame reproduces the tensor
    b = wd.ModelBuilder()
    b.add_material("m", soil())
    b.add_clump(centres, radii, "m")
    model, state = b.finalize(DEVICE)
    rot = quat_to_matrix(state.body_quat.numpy()[0])
    world = rot @ np.diag(model.body_inertia.numpy()[0]) @ rot.T
    np.testing.assert_allclose(world, inertia, rtol=0, atol=1e-9 * np.abs(inertia).max())


def test_add_clumps_matches_trimesh_and_add_clump() -> None:
    # Reference: trimesh's volume integrals of each clump's concatenated member icospheres (Yade's rule, as above;
    # tolerance: icosphere volume error); geometry: the members' world centres from the body frame. Clumps of 1-4
    # members, one of them three collinear spheres (two equal principal moments). The same
    # clumps one by one with add_clump must give the same bits: both share one code path, and a degenerate clump's
    # frame is left to rounding, so anything else would make a bed's run depend on how it was built.
    import trimesh

    from warpdem.mass import quats_to_matrices

    rng = np.random.default_rng(3)
    sizes = np.array([3, 1, 2, 4, 3, 2])
    centres, radii = [], []
    for k, size in enumerate(sizes):
        base = np.array([0.1 * k, 0.0, 0.0])
        if k == 0:  # collinear
            offs = np.array([[-0.01, 0.0, 0.0], [0.0, 0.0, 0.0], [0.01, 0.0, 0.0]])
        else:
            offs = rng.uniform(-0.008, 0.008, (size, 3))
        centres.append(base + offs)
        radii.append(rng.uniform(0.006, 0.01, size) if k else np.full(3, 0.008))
    centres, radii = np.concatenate(centres), np.concatenate(radii)
    b = wd.ModelBuilder()
    b.add_material("m", soil())
    ids = b.add_clumps(centres, radii, sizes, "m")
    one = wd.ModelBuilder()
    one.add_material("m", soil())
    first = np.r_[0, np.cumsum(sizes)[:-1]]
    for f, size in zip(first, sizes, strict=True):
        one.add_clump(centres[f:f + size], radii[f:f + size], "m")
    for key in ("pos", "quat", "mass", "inertia"):
        assert np.array_equal(b.body_array(key), one.body_array(key)), key
    assert np.array_equal(np.concatenate(b.sphere_offset), np.concatenate(one.sphere_offset))
    model, state = b.finalize(DEVICE)
    rot = quats_to_matrices(state.body_quat.numpy())
    pos = state.body_pos.numpy()
    owner = np.repeat(ids, sizes)
    world = pos[owner] + np.einsum("nij,nj->ni", rot[owner], model.sphere_offset.numpy())
    np.testing.assert_allclose(world, centres, rtol=0, atol=1e-9)  # the model keeps offsets in float32: 6e-8 x 1 cm
    for c, (f, size) in enumerate(zip(first, sizes, strict=True)):
        mesh = trimesh.util.concatenate([trimesh.creation.icosphere(subdivisions=4, radius=r).apply_translation(x)
                                         for x, r in zip(centres[f:f + size], radii[f:f + size], strict=True)])
        mesh.density = RHO
        assert model.body_mass.numpy()[c] == pytest.approx(mesh.mass, rel=5e-3)
        np.testing.assert_allclose(pos[c], mesh.center_mass, atol=1e-5)
        tensor = rot[c] @ np.diag(model.body_inertia.numpy()[c]) @ rot[c].T
        np.testing.assert_allclose(tensor, mesh.moment_inertia, rtol=0, atol=1e-2 * np.abs(tensor).max())


def random_cloud(n: int, seed: int, box: float) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    pos, rad = [], []
    while len(pos) < n:
        r = rng.uniform(0.004, 0.006)
        p = rng.uniform(-box, box, 3)
        if all(np.linalg.norm(p - q) > r + s for q, s in zip(pos, rad, strict=True)):
            pos.append(p)
            rad.append(r)
    return np.array(pos), np.array(rad)


def test_momentum_conservation() -> None:
    # Reference: contact forces are equal and opposite (Newton's third law), so without gravity, damping or walls
    # the total linear momentum is constant and the angular momentum about the origin too. Tolerance: float32
    # forces accumulated over 3000 steps, 1e-5 of the momentum scale.
    pos, rad = random_cloud(40, 3, 0.03)
    rng = np.random.default_rng(4)
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("c", soil(normal_cohesion=1e3, shear_cohesion=1e3, moment_law=True, eta_roll=0.2, eta_twist=0.2))
    b.add_spheres(pos, rad, "c", velocities=rng.normal(0, 0.3, (40, 3)), angular_velocities=rng.normal(0, 5, (40, 3)))
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=2e-6, cohesion_on_new_contacts=True)

    def momenta() -> tuple[np.ndarray, np.ndarray]:
        m = model.host["body_mass"][:, None]
        x, v = state.body_pos.numpy(), state.body_vel.numpy()
        ang = (np.cross(x, m * v) + model.host["body_inertia"] * state.body_angvel.numpy()).sum(axis=0)
        return (m * v).sum(axis=0), ang

    p0, l0 = momenta()
    sim.advance(3000)
    assert obs.contact_count(sim)[0, 0] > 0 or sim.rebuild_count > 0
    p1, l1 = momenta()
    scale = (model.host["body_mass"] * np.linalg.norm(state.body_vel.numpy(), axis=1)).sum()
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(l1, l0, rtol=0, atol=1e-5 * scale * 0.05)


def test_energy_balance() -> None:
    # Reference: kinetic + elastic + gravity potential + dissipated (local damping, sliding, rolling) is constant
    # (no driven bodies). Spheres with cohesion, rolling resistance and damping fall into a facet box and settle.
    # Tolerance: 3 % of the energy initially available (leapfrog's O(dt) phase lag between velocity and position
    # terms, and the impact at the floor); the dissipated share is over 50 %, so a missing term would show.
    pos, rad = random_cloud(30, 5, 0.02)
    pos[:, 2] += 0.04
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_material("c", soil(normal_cohesion=2e3, shear_cohesion=1e3, moment_law=True, eta_roll=0.2, eta_twist=0.2))
    b.add_material("w", soil())
    b.add_spheres(pos, rad, "c", group="soil")
    for k, (c, tilt) in enumerate([((0, 0, 0), 0.0)]):
        v, f = square(c, 0.05, tilt)
        b.add_mesh(f"floor{k}", v, f, "w")
    b.set_local_damping("soil", 0.2)
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=5e-6, cohesion_on_new_contacts=True, track_energy=True)
    e0 = obs.energy_balance(sim)
    sim.advance(20000)
    e1 = obs.energy_balance(sim)
    available = e0["gravity"][0] - e1["gravity"][0] + e0["kinetic"][0]
    dissipated = sum(e1[k][0] for k in e1 if k.startswith("dissipated"))
    assert dissipated > 0.5 * available
    assert e1["total"][0] == pytest.approx(e0["total"][0], abs=0.03 * available)


def test_driven_work_of_imposed_velocities_and_kinematic_bodies() -> None:
    # Reference: a sphere dragged at constant speed v over a floor (rotations blocked) slides at the friction force
    # tan(phi) m g, so the driver works at tan(phi) m g v and all of it is dissipated by sliding. World 0 drags the
    # sphere (x blocked, imposed v) over a kinematic floor at rest; world 1 holds the sphere (imposed 0) and moves
    # the floor at -v (a kinematic body doing the work). Over the second half (the normal bounce damped out by
    # local damping on z): driven work = tan(phi) m g v t within 1 % (float32 forces, the residual bounce); the
    # balance (kinetic + elastic + gravity + dissipated - driven work) holds from the start within 1e-3 of the work.
    phi, v, dt, n = 30.0, 0.05, 2e-6, 20000
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_material("m", soil(friction_angle=phi))
    kn = 4 * E * R / 3  # sphere-facet: 2 (E R)(E 2R) / (E R + E 2R), the facet counted with radius 2R (Yade)
    b.add_sphere((0, 0, R - MASS * 9.81 / kn), R, "m", blocked="xXYZ", name="ball", group="ball")
    verts, faces = square((0, 0, 0), 0.2)
    b.add_mesh("floor", verts, faces, "m", kind="kinematic")
    b.set_local_damping("ball", 0.3)
    model, state = b.finalize(DEVICE, n_worlds=2, overrides={"body:ball:velocity": [[v, 0, 0], [0, 0, 0]],
                                                             "body:floor:velocity": [[0, 0, 0], [-v, 0, 0]]})
    sim = wd.Simulation(model, state, dt=dt, track_energy=True)
    e0 = obs.energy_balance(sim)
    sim.advance(n)
    e_half = obs.energy_balance(sim)
    sim.advance(n)
    e_end = obs.energy_balance(sim)
    expected = np.tan(np.radians(phi)) * MASS * 9.81 * v * n * dt
    np.testing.assert_allclose(e_end["driven_work"] - e_half["driven_work"], expected, rtol=1e-2)
    np.testing.assert_allclose(e_end["dissipated_sliding"] - e_half["dissipated_sliding"], expected, rtol=1e-2)
    np.testing.assert_allclose(e_end["total"], e0["total"], atol=1e-3 * e_end["driven_work"].min())


def test_driven_work_of_a_carried_pivot() -> None:
    # Reference: a pendulum hinged at a pivot carried at constant velocity u conserves its energy in the carriage's
    # frame; in the lab frame the kinetic energy swings by m u . v' and the carriage's work (pivot reaction times u)
    # pays for it, so kinetic + gravity - driven work stays constant. Tolerance: 1e-3 of the swing of the driven
    # work (leapfrog's O(omega dt) lag between the velocity and position terms: omega dt = 7e-4 with dt = 1e-4 s
    # on a 0.9 s period).
    m, d = 2.0, 0.3
    inertia = np.array([[0.05, 0.004, -0.002], [0.004, 0.045, 0.01], [-0.002, 0.01, 0.012]])
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_rigid_body((0, 0, -d), mass=m, inertia=inertia, blocked="YZ", pivot=(0, 0, 0), name="tool",
                     angular_velocity=(2.0, 0, 0), velocity=(0, 0.6, 0))
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=1e-4, track_energy=True, bounds=((-1, -1, -2), (1, 5, 1)))
    total, work = [], []
    for _ in range(100):
        sim.advance(100)
        e = obs.energy_balance(sim)
        total.append(e["total"][0])
        work.append(e["driven_work"][0])
    swing = np.ptp(work)
    assert swing > 0.5  # m u v' ~ 2 kg x 0.6 m/s x 0.6 m/s: a term the balance cannot miss
    assert np.ptp(total) < 1e-3 * swing


def test_energy_balance_of_a_damped_body_turning_about_one_free_axis() -> None:
    # Reference: kinetic + spring elastic + dissipated is constant for a body that may only turn about z (x, y
    # rotations and all translations blocked at zero velocity: the drivers do no work), pulled round by a spring
    # and slowed by local damping. Tolerance: 1 % of the energy dissipated (leapfrog's O(dt) phase lag, dt = 1e-4 s
    # against a 0.36 s period); the damping must take a large share, so a missing term would show.
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    anchor = b.add_rigid_body((0.5, 0.3, 0.0), name="anchor")
    body = b.add_rigid_body((0, 0, 0), mass=2.0, inertia=np.diag([0.1, 0.1, 0.2]), blocked="xyzXY", name="rotor",
                            group="rotor")
    b.add_spring("spring", anchor, (0.5, 0.3, 0.0), body, (0.4, 0.0, 0.0), stiffness=200.0, rest_length=0.1)
    b.set_local_damping("rotor", 0.1)
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=1e-4, track_energy=True)
    sim.step()  # the spring's elastic energy is read from its last step
    e0 = obs.energy_balance(sim)
    sim.advance(20000)
    e1 = obs.energy_balance(sim)
    assert e1["dissipated_damping"][0] > 0.3 * e0["total"][0]
    assert e1["driven_work"][0] == pytest.approx(0.0, abs=1e-9)
    assert e1["total"][0] == pytest.approx(e0["total"][0], abs=0.01 * e1["dissipated_damping"][0])


def test_a_rotation_step_is_the_axis_angle_rotation() -> None:
    # Reference: the rotation by the angle |omega| dt about omega, q' = (sin(h) omega / |omega|, cos h) q with
    # h = |omega| dt / 2, in numpy's float64 (Hamilton product written out). Half angles from 1e-9 to 0.3 rad,
    # both sides of 0.01 rad (where a series form of the step may hand over to sine and cosine), and omega = 0
    # (q unchanged).
    # Tolerance 6e-16: float64 rounding of the rotation, a product and a normalisation (a few 1.1e-16).
    import warp as wp

    from warpdem.integrator import quat_integrate

    @wp.kernel
    def step(q: wp.array(dtype=wp.quatd), w: wp.array(dtype=wp.vec3d), dt: wp.float64,
             out: wp.array(dtype=wp.quatd)):
        i = wp.tid()
        out[i] = quat_integrate(q[i], w[i], dt)

    rng = np.random.default_rng(3)
    n = 64
    axis = rng.standard_normal((n, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    dt = 1e-4
    half = np.r_[0.0, np.geomspace(1e-9, 0.3, n - 1)]
    w = axis * (2 * half / dt)[:, None]
    q = rng.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    out = wp.zeros(n, dtype=wp.quatd, device=DEVICE)
    wp.launch(step, n, inputs=[wp.array(q, dtype=wp.quatd, device=DEVICE), wp.array(w, dtype=wp.vec3d, device=DEVICE),
                               wp.float64(dt)], outputs=[out], device=DEVICE)
    dq = np.c_[axis * np.sin(half)[:, None], np.cos(half)]  # (x, y, z, w)
    av, aw, bv, bw = dq[:, :3], dq[:, 3:], q[:, :3], q[:, 3:]
    ref = np.c_[aw * bv + bw * av + np.cross(av, bv), aw * bw - np.sum(av * bv, axis=1, keepdims=True)]
    ref /= np.linalg.norm(ref, axis=1)[:, None]
    np.testing.assert_allclose(out.numpy(), ref, rtol=0, atol=6e-16)
    np.testing.assert_array_equal(out.numpy()[0], q[0])  # no rotation: q as it was


def _pair_incline(theta: float, pair: list[float] | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """incline_run's sphere (20 deg) on its wall (60 deg), the pair's own angle per world (``pair``) or none: each
    world's sphere motion over the first and both halves of 4,000 steps and its acceleration over the second [m/s^2]."""
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_material("s", soil(friction_angle=20.0))
    b.add_material("w", soil(friction_angle=60.0))
    v, f = square((0, 0, 0), 0.5, theta)
    b.add_mesh("plane", v, f, "w")
    t = np.radians(theta)
    start = np.array([0.2, -0.2, 0.0])
    start[2] = -np.tan(t) * start[0] + (R - MASS * 9.81 * np.cos(t) / (4.0 / 3.0 * E * R)) / np.cos(t)
    b.add_sphere(start, R, "s", blocked="XYZ")
    if pair is not None:
        b.set_pair_friction("s", "w", pair[0])
    model, state = b.finalize(DEVICE, n_worlds=len(pair or [0]),
                              overrides={"pair:s:w:friction_angle": pair} if pair else None)
    k = 1 + 2 * np.arange(len(pair or [0]))  # each world's sphere (after its plane)
    dt, half_steps = 2e-5, 2000
    sim = wd.Simulation(model, state, dt=dt)
    x0 = state.body_pos.numpy()[k].copy()
    sim.advance(half_steps)
    half, v_half = state.body_pos.numpy()[k] - x0, state.body_vel.numpy()[k].copy()
    sim.advance(half_steps)
    return half, state.body_pos.numpy()[k] - x0, (state.body_vel.numpy()[k] - v_half) / (half_steps * dt)


def test_a_pair_friction_angle_replaces_the_smaller_of_the_two() -> None:
    """Reference: Coulomb on an incline, the contact's friction angle being the pair's own where one is set (Yade's
    MatchMaker on Ip2_CohFrictMat_CohFrictMat_CohFrictPhys.frictAngle) and min(phi_sphere, phi_wall) otherwise.
    Sphere 20 deg, wall 60 deg, incline 25 deg: no pair angle (20 deg) slides with a = g (sin 25 - cos 25 tan 20);
    two worlds with the pair's own 30 deg (sticks: under 0.1 um of motion over the second half) and 22 deg (slides
    with tan 22). Tolerance on a: 0.2 % (float32 forces), as the incline test above."""
    t = np.radians(25.0)
    _, _, acc0 = _pair_incline(25.0, None)
    half, d, acc = _pair_incline(25.0, [30.0, 22.0])
    assert np.linalg.norm(d[0] - half[0]) < 1e-7
    for a, phi in ((acc0[0], 20.0), (acc[1], 22.0)):
        assert np.linalg.norm(a) == pytest.approx(9.81 * (np.sin(t) - np.cos(t) * np.tan(np.radians(phi))), rel=2e-3)
    b = wd.ModelBuilder()
    b.add_material("s", soil())
    with pytest.raises(wd.InputError, match="pair friction_angle"):
        b.set_pair_friction("s", "s", 90.0)


def test_a_sphere_gets_one_contact_where_triangles_share_its_closest_point() -> None:
    # Reference: one linear contact, Fn = kn un with kn = 4/3 E R (facet contact radius 2R), for a sphere above a
    # square's diagonal (the two triangles' shared edge, which rounding put inside both on CUDA: two contacts) and
    # 1e-14 m beside it (inside one triangle by a rounding's width: its edge's, geometry.EDGE_MARGIN). Tolerance:
    # the float32 force, rel 1e-5.
    kn, un = 4.0 / 3.0 * E * R, 1e-5
    v, f = square((0, 0, 0), 0.05)
    for x, y in [(0.0, 0.0), (1e-14, 0.0), (0.0, 1e-14)]:
        b = wd.ModelBuilder(gravity=(0, 0, 0))
        b.add_material("soil", soil())
        b.add_sphere((x, y, R - un), R, "soil", blocked="xyzXYZ")
        b.add_mesh("plate", v, f, "soil")
        model, state = b.finalize(DEVICE)
        sim = wd.Simulation(model, state, dt=1e-6)
        sim.step()
        assert sim.data.body_force.numpy()[0, 2] == pytest.approx(kn * un, rel=1e-5), (x, y)


def pulled_off_facet(adhesion: list[float], steps: int) -> tuple[np.ndarray, np.ndarray]:
    """A soil sphere pushed 10 um into a static steel square, then pulled straight off it at 0.01 m/s, one world per
    ``adhesion`` of the soil-steel pair [Pa] (negative: none); returns (un (steps,), Fn (steps, worlds)), Fn the
    normal force on the sphere (positive in compression)."""
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("soil", soil())
    b.add_material("steel", soil())
    b.set_pair_adhesion("soil", "steel", 1.0)
    b.add_sphere((0, 0, R - 1e-5), R, "soil", blocked="xyzXYZ", velocity=(0, 0, 0.01))
    b.add_mesh("plate", *square((0, 0, 0), 0.05), "steel")
    model, state = b.finalize(DEVICE, n_worlds=len(adhesion), overrides={"pair:soil:steel:adhesion": adhesion})
    sim = wd.Simulation(model, state, dt=1e-6)
    sphere = np.arange(len(adhesion)) * model.bodies_per_world
    un, fn = [], []
    for _ in range(steps):
        un.append(R - state.body_pos.numpy()[sphere[0], 2])  # the overlap the step's force is computed at
        sim.step()
        fn.append(sim.data.body_force.numpy()[sphere, 2].astype(np.float64))
    return np.asarray(un), np.asarray(fn)


def test_a_pairs_adhesion_bonds_its_new_contacts_to_their_strength() -> None:
    # Reference: Yade's cohesive bond of CohFrictPhys, given here to every new contact of one material pair
    # (ModelBuilder.set_pair_adhesion) and to no other: its strength a_n = C_a min(R1, R2)^2, min(R1, R2) = R for a
    # facet (contact radius 2R), so C_a = 2e4 Pa gives 2 N; kn = 2 (E 2R)(E R) / (E 2R + E R) = 4/3 E R =
    # 1.33e5 N/m. The fragile bond carries tension kn un down to un = -a_n / kn = -15 um, then none; without the
    # pair's adhesion (the other world: the simulation's rule, no cohesion on new contacts) the contact carries no
    # tension at all. Tolerance: one step of pulling, v dt kn = 1.3e-3 N.
    kn, an = 4.0 / 3.0 * E * R, 2e4 * R**2
    un, fn = pulled_off_facet([2e4, -1.0], 4000)
    bonded, free = fn[:, 0], fn[:, 1]
    assert bonded.min() == pytest.approx(-an, abs=1.4e-3)
    broke = int(np.argmax((un < 0) & (bonded == 0.0)))
    assert un[broke] == pytest.approx(-an / kn, abs=1.1e-8)
    assert np.all(bonded[broke:] == 0.0)
    touching = un > 1e-7
    np.testing.assert_allclose(bonded[touching], kn * un[touching], rtol=1e-3, atol=1.4e-3)
    assert free.min() >= 0.0 and np.all(free[un < 0] == 0.0)
    np.testing.assert_allclose(free[touching], bonded[touching], rtol=1e-6)
    hm = wd.ModelBuilder()
    hm.add_material("a", wd.HertzMindlinMaterial(young=1e7, poisson=0.3, density=2600, friction_angle=25))
    with pytest.raises(wd.InputError, match="pair adhesion needs cohesive-frictional"):
        hm.set_pair_adhesion("a", "a", 1e3)
    cf = wd.ModelBuilder()
    cf.add_material("s", soil())
    with pytest.raises(wd.InputError, match="pair adhesion"):
        cf.set_pair_adhesion("s", "s", -1.0)
