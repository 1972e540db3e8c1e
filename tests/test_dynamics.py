"""Rigid-body dynamics: springs, aspherical rotation, hinged (partly blocked) rotation, mesh contacts."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEVICE, square

import warpdem as wd
from warpdem.mass import quat_to_matrix, quats_to_matrices

STEEL = wd.Material(young=2e8, poisson=0.3, density=7850.0, friction_angle=30.0)


def test_spring_dashpot_oscillator() -> None:
    # Reference: a mass m on a linear spring k with dashpot c oscillates at w_d = w0 sqrt(1 - z^2), w0 = sqrt(k/m),
    # z = c / (2 sqrt(k m)), amplitude decaying as exp(-z w0 t). Tolerance: leapfrog's frequency error
    # (w0 dt)^2/24 ~ 1e-6 plus 1 % for peak picking on the sampled signal.
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    carriage = b.add_rigid_body((0, 0, 0), name="carriage")
    m, k, c = 2.0, 20000.0, 8.0
    mass = b.add_rigid_body((0.1, 0, 0), mass=m, inertia=np.eye(3) * 1e-3, blocked="yzXYZ", name="mass",
                            velocity=(0.2, 0, 0))
    b.add_spring("s", carriage, (0, 0, 0), mass, (0.1, 0, 0), stiffness=k, damping=c)
    b.add_material("m", STEEL)
    model, state = b.finalize(DEVICE)
    dt = 1e-4
    sim = wd.Simulation(model, state, dt=dt)
    out = sim.run(4000, record_every=1, observers={"x": lambda s: s.state.body_pos.numpy()[mass, 0] - 0.1})
    x = out["x"]
    w0 = np.sqrt(k / m)
    z = c / (2 * np.sqrt(k * m))
    peaks = np.nonzero((x[1:-1] > x[:-2]) & (x[1:-1] > x[2:]))[0] + 1
    period = np.diff(out["time"][peaks]).mean()
    assert 2 * np.pi / period == pytest.approx(w0 * np.sqrt(1 - z**2), rel=1e-2)
    decay = np.log(x[peaks[0]] / x[peaks[4]]) / (out["time"][peaks[4]] - out["time"][peaks[0]])
    assert decay == pytest.approx(z * w0, rel=2e-2)


def tumbling_clump(dt: float, t_end: float) -> tuple[np.ndarray, np.ndarray, float, float, np.ndarray]:
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("m", STEEL)
    b.add_clump([[0, 0, 0], [0.03, 0, 0], [0, 0.015, 0]], [0.01, 0.01, 0.01], "m",
                angular_velocity=(0.05, 20.0, 0.05), name="c")
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=dt, force_dt=True)
    l0 = state.body_angmom.numpy()[0].copy()
    e0 = wd.observers.kinetic_energy(sim)[0]
    q0 = state.body_quat.numpy()[0].copy()
    sim.advance(round(t_end / dt))
    return l0, state.body_angmom.numpy()[0], e0, wd.observers.kinetic_energy(sim)[0], state.body_quat.numpy()[0] - q0


def test_torque_free_aspherical_body_conserves_momentum_and_energy() -> None:
    # Reference: Euler's equations without torque conserve the world angular momentum L exactly (Yade's scheme
    # integrates L) and the kinetic energy L . w / 2. A clump tumbling about its intermediate axis (unstable)
    # exercises the full rotation. Tolerance: 1e-12 on L; the energy error must be small (< 0.5 %) and converge at
    # first order: Yade's leapfrogAsphericalRotate (which warpdem copies) maps the half-step angular momentum to the
    # body frame with the orientation of step n, an O(dt) error, so halving dt halves it (ratio 1.8..2.2).
    l0, l1, e0, e1, dq = tumbling_clump(1e-4, 0.3)
    np.testing.assert_allclose(l1, l0, rtol=0, atol=1e-12)
    assert np.abs(dq).max() > 0.1  # it really tumbled
    err = abs(e1 / e0 - 1)
    assert err < 5e-3
    _, _, e0h, e1h, _ = tumbling_clump(5e-5, 0.3)
    assert 1.8 < err / abs(e1h / e0h - 1) < 2.2


def test_hinged_body_rotates_about_the_free_axis_only() -> None:
    # Reference: a body with rotations blocked about y and z and a constant torque T about x accelerates as
    # T / I_xx(world), whatever its products of inertia (the tool of the paper rotates about one axis). Yade's
    # aspherical scheme would leak rotation into the blocked axes. Tolerance: float64 round-off.
    b = wd.ModelBuilder(gravity=(0, -9.81, 0))
    inertia = np.array([[2.6007, -0.0192, -0.0083], [-0.0192, 0.7211, 0.2], [-0.0083, 0.2, 1.9056]])
    body = b.add_rigid_body((0, 0, 0), mass=7.692, inertia=inertia, blocked="xyzYZ", name="tool")
    carriage = b.add_rigid_body((0, 0.5, 0), name="pin")
    # a spring pulling along y at a lever arm along z gives a torque about x
    b.add_spring("s", carriage, (0, 0.5, 0.2), body, (0, 0, 0.2), stiffness=0.0, preload=10.0)
    b.add_material("m", STEEL)
    model, state = b.finalize(DEVICE)
    dt = 1e-5
    sim = wd.Simulation(model, state, dt=dt)
    sim.advance(10)
    w = state.body_angvel.numpy()[body]
    assert w[1] == 0.0 and w[2] == 0.0
    t_x = -10.0 * 0.2  # preload pulls +y at z = 0.2: torque (0, 0, 0.2) x (0, 10, 0) = (-2, 0, 0)
    assert w[0] == pytest.approx(10 * dt * t_x / inertia[0, 0], rel=1e-3)


def test_sphere_rolling_across_mesh_diagonal_has_no_force_jump() -> None:
    # Reference: a sphere sliding over a flat two-triangle square keeps Fn = m g when it crosses the shared diagonal
    # (Yade would add an edge contact and double the force there). Tolerance: float32 force noise, 1e-3.
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    soil = wd.Material(young=1e7, poisson=0.3, density=2700.0, friction_angle=0.0)
    b.add_material("s", soil)
    v, f = square((0, 0, 0), 0.1)
    b.add_mesh("floor", v, f, "s")
    r = 0.01
    mass = 2700 * 4 / 3 * np.pi * r**3
    overlap = mass * 9.81 / (4 / 3 * 1e7 * r)
    b.add_sphere((-0.02, 0.0, r - overlap), r, "s", velocity=(0.5, 0, 0), blocked="XYZ")
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=2e-5)
    fz = []
    for _ in range(4000):  # 4 cm: crosses the diagonal y = x at x = 0
        sim.step()
        fz.append(sim.data.body_force.numpy()[1, 2])
    fz = np.asarray(fz)
    assert np.abs(fz / (mass * 9.81) - 1).max() < 1e-3
    assert state.body_pos.numpy()[1, 0] > 0.01


def test_mesh_plane_rebound_independent_of_tessellation() -> None:
    # Reference: a sphere dropped on a plane rebounds the same whether the plane is 2 or 32 triangles (DEME #73):
    # same maximum normal force and same rebound velocity. Tolerance: 1e-4.
    results = []
    for n in (1, 4):
        b = wd.ModelBuilder(gravity=(0, 0, -9.81))
        b.add_material("s", wd.Material(young=1e7, poisson=0.3, density=2700.0, friction_angle=30.0))
        verts, faces = [], []
        h = 0.1 / n
        for i in range(n):
            for j in range(n):
                v, f = square((-0.1 + h + 2 * h * i, -0.1 + h + 2 * h * j, 0), h)
                faces.append(f + len(verts) * 4)
                verts.append(v)
        b.add_mesh("floor", np.concatenate(verts), np.concatenate(faces), "s")
        b.add_sphere((0.013, 0.027, 0.0105), 0.01, "s", velocity=(0.3, 0.1, -0.5))
        model, state = b.finalize(DEVICE)
        sim = wd.Simulation(model, state, dt=2e-6)
        fmax = 0.0
        for _ in range(1500):
            sim.step()
            fmax = max(fmax, float(sim.data.body_force.numpy()[1, 2]))
        results.append((fmax, state.body_vel.numpy()[1].copy()))
    assert results[1][0] == pytest.approx(results[0][0], rel=1e-4)
    np.testing.assert_allclose(results[1][1], results[0][1], rtol=0, atol=1e-4 * 0.5)


def test_dynamic_mesh_inertia_from_trimesh() -> None:
    # Reference: trimesh's mass properties of a closed box, m = rho V and I = m (b^2 + c^2)/12 about its centre;
    # the builder stores them in the principal frame. Tolerance: float round-off.
    import trimesh

    box = trimesh.creation.box(extents=(0.3, 0.2, 0.1))
    b = wd.ModelBuilder()
    b.add_material("m", STEEL)
    b.add_mesh("box", np.asarray(box.vertices) + 1.0, np.asarray(box.faces), "m", kind="dynamic")
    model, state = b.finalize(DEVICE)
    m = 7850 * 0.3 * 0.2 * 0.1
    assert model.host["body_mass"][0] == pytest.approx(m)
    rot = quat_to_matrix(state.body_quat.numpy()[0])
    tensor = rot @ np.diag(model.host["body_inertia"][0]) @ rot.T
    np.testing.assert_allclose(np.diag(tensor), m / 12 * np.array([0.05, 0.1, 0.13]), rtol=1e-9)
    np.testing.assert_allclose(state.body_pos.numpy()[0], 1.0, atol=1e-12)


def test_hinged_pendulum_period_and_moving_pivot() -> None:
    # Reference: a rigid body hinged about the x axis through a pivot, its centre of mass d below it, swings with
    # omega_n^2 = m g d / I_p, I_p = I_xx(com) + m d^2 (small amplitude; the finite amplitude theta0 = 0.015 rad
    # lengthens the period by theta0^2 / 16 = 1.4e-5). The inertia has products of inertia (like the sweep's) that
    # must not leak rotation into the blocked axes. A pivot carried at constant velocity (world 1) is an inertial
    # frame: same period, and the pivot stays exactly on the carriage path. Tolerances: period from interpolated
    # zero crossings of omega_x, 2e-4 (sampling 1e-4 s on a 0.9 s period, over 5 periods); pivot path 1e-12 m.
    m, d = 2.0, 0.3
    inertia = np.array([[0.05, 0.004, -0.002], [0.004, 0.045, 0.01], [-0.002, 0.01, 0.012]])
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    body = b.add_rigid_body((0, 0, -d), mass=m, inertia=inertia, blocked="YZ", pivot=(0, 0, 0), name="tool",
                            angular_velocity=(0.1, 0, 0))
    speed = np.array([0.0, 0.6, 0.0])
    model, state = b.finalize(DEVICE, n_worlds=2, overrides={"body:tool:velocity": [[0, 0, 0], speed]})
    dt = 1e-4
    sim = wd.Simulation(model, state, dt=dt, bounds=((-1, -1, -1), (1, 5, 1)))
    i_p = inertia[0, 0] + m * d**2
    period = 2 * np.pi / np.sqrt(m * 9.81 * d / i_p)
    n = int(5.2 * period / dt)
    w = np.empty((n, 2, 3))
    pivots = np.empty((n, 2, 3))
    pivot_point = wd.observers.body_point("tool", (0, 0, 0))  # fixed to the swinging body, 0.3 m from its centre
    pivot_point(sim)
    for k in range(n):
        sim.step()
        s = state.numpy()
        w[k] = s["body_angvel"]
        rot = quats_to_matrices(s["body_quat"])
        pivots[k] = s["body_pos"] + np.einsum("nij,nj->ni", rot, model.host["body_pivot"])
    t = (np.arange(n) + 1) * dt
    for world in range(2):
        assert np.abs(w[:, world, 1:]).max() == 0.0
        wx = w[:, world, 0]
        theta0 = np.abs(wx).max() / np.sqrt(m * 9.81 * d / i_p)
        assert theta0 < 0.02
        down = np.nonzero((wx[:-1] > 0) & (wx[1:] <= 0))[0]
        tz = t[down] + dt * wx[down] / (wx[down] - wx[down + 1])
        measured = (tz[-1] - tz[0]) / (len(tz) - 1)
        assert measured == pytest.approx(period * (1 + theta0**2 / 16), rel=2e-4)
    np.testing.assert_allclose(pivots[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(pivots[:, 1], t[:, None] * speed, atol=1e-12)
    np.testing.assert_allclose(pivot_point(sim), pivots[-1], atol=1e-12)
    assert body == 0
    # the device's gather of one body's pose per world gives the whole arrays' rows (reference: numpy indexing)
    for gather in (True, False):
        pos, quat = wd.observers.body_poses(sim, "tool", gather=gather)
        np.testing.assert_array_equal(pos, state.body_pos.numpy()[[0, 1]])
        np.testing.assert_array_equal(quat, state.body_quat.numpy()[[0, 1]])


def _peaks(x: np.ndarray) -> np.ndarray:
    return np.nonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:]))[0] + 1


def test_progressive_spring_period_and_mass_override() -> None:
    # Reference: an undamped Duffing oscillator m x'' = -(k x + k3 x^3) released from rest at amplitude A has the
    # period T = 4 int_0^A dx / sqrt(2 (V(A) - V(x)) / m), V = k x^2/2 + k3 x^4/4 (exact, by quadrature); a
    # ``body:<name>:mass`` override gives world 1 a mass 2.25 times heavier (period 1.5 times longer for k3 = 0).
    # Tolerance: 2e-3 on the period (dt = 1e-5 s against periods of 0.04-0.1 s, zero crossings interpolated);
    # energy (kinetic + spring) conserved within 1e-2: the leapfrog's velocity lags the position by dt/2, a ripple
    # of order omega dt in the sampled energy (the stiffest tangent, k + 3 k3 A^2, gives omega dt = 5e-3).
    from scipy.integrate import quad

    m, k, k3, amp = 2.0, 2.0e4, 4.0e8, 0.02
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    carriage = b.add_rigid_body((0, 0, 0), name="carriage")
    body = b.add_rigid_body((0.1 + amp, 0, 0), mass=m, inertia=np.eye(3) * 1e-3, blocked="yzXYZ", name="mass")
    b.add_spring("s", carriage, (0, 0, 0), body, (0.1 + amp, 0, 0), stiffness=k, rest_length=0.1)
    model, state = b.finalize(DEVICE, n_worlds=3, overrides={"spring:s:progressive": [k3, 0.0, 0.0],
                                                              "body:mass:mass": [m, m, 2.25 * m]})
    dt = 1e-5
    sim = wd.Simulation(model, state, dt=dt, track_energy=True)
    out = sim.run(25000, record_every=1, observers={
        "x": lambda s: s.state.body_pos.numpy()[body::2, 0] - 0.1,
        "e": lambda s: wd.observers.kinetic_energy(s) + wd.observers.spring_elastic_energy(s),
    })
    x, t = out["x"], out["time"]

    def v(y: float, kk3: float) -> float:
        return 0.5 * k * y**2 + 0.25 * kk3 * y**4

    def period(kk3: float, mass: float) -> float:
        return 4 * quad(lambda y: 1 / np.sqrt(2 * (v(amp, kk3) - v(y, kk3)) / mass), 0, amp, limit=200)[0]

    for world, (kk3, mass) in enumerate([(k3, m), (0.0, m), (0.0, 2.25 * m)]):
        xw = x[:, world]
        up = np.nonzero((xw[:-1] < 0) & (xw[1:] >= 0))[0]
        tz = t[up] - dt * xw[up] / (xw[up + 1] - xw[up])
        assert (tz[-1] - tz[0]) / (len(tz) - 1) == pytest.approx(period(kk3, mass), rel=2e-3)
        e = out["e"][1:, world]  # from the first step on (the spring force is computed by a step)
        assert np.ptp(e) < 1e-2 * e.mean()
    assert period(k3, m) < 0.8 * period(0.0, m)  # the cubic term matters at this amplitude


def test_preloaded_spring_rests_on_its_stop_until_the_load_exceeds_the_preload() -> None:
    # Reference (statics in closed form): a mass m pressed against a spring by its weight m g, the spring preloaded
    # in compression by P0 against a stop at its rest length (stop stiffness ks). Below the preload the mass rests
    # on the stop, pushed into it by (P0 - m g) / (k + ks); above it, the spring gives way by (m g - P0) / k, as a
    # spring without a stop would from P0 on. Worlds 0-2: P0 = 0, m g / 2, 2 m g, damped to rest (zeta 0.5, 1 s =
    # 16 periods of the softest side: the residual motion is e^-50 of the start). Tolerance: 1e-4 of m g / k (the
    # float32 spring parameters: 1e-7 relative). World 3 bounces off the stop undamped: kinetic + gravity + spring
    # energy (the stop's included) is conserved within 2 % of the kinetic energy it starts with: leapfrog's sampled
    # energy ripples by about omega dt = 0.017 of it on the stop's side (dt = 5e-5 s); a stop energy left out would
    # miss about all of it at every bounce.
    m, k, ks, g = 2.0, 2.0e4, 2.0e5, 9.81
    b = wd.ModelBuilder(gravity=(-g, 0, 0))
    carriage = b.add_rigid_body((0, 0, 0), name="carriage")
    body = b.add_rigid_body((0.1, 0, 0), mass=m, inertia=np.eye(3) * 1e-3, blocked="yzXYZ", name="mass")
    b.add_spring("s", carriage, (0, 0, 0), body, (0.1, 0, 0), stiffness=k, rest_length=0.1, stop_stiffness=ks)
    preload = np.array([0.0, 0.5, 2.0, 0.5]) * m * g
    c = 2 * 0.5 * np.sqrt(k * m)
    model, state = b.finalize(DEVICE, n_worlds=4, overrides={
        "spring:s:preload": -preload, "spring:s:damping": [c, c, c, 0.0],
        "body:mass:velocity": [(0, 0, 0)] * 3 + [(0.3, 0, 0)]})
    dt = 5e-5
    sim = wd.Simulation(model, state, dt=dt, track_energy=True)

    def energy(s: wd.Simulation) -> np.ndarray:
        x = s.state.body_pos.numpy()[body::2, 0]
        return wd.observers.kinetic_energy(s) + wd.observers.spring_elastic_energy(s) + m * g * x

    out = sim.run(20000, record_every=20, observers={"e": energy})
    u = sim.state.body_pos.numpy()[body::2, 0] - 0.1
    expected = [-m * g / k, -(m * g - preload[1]) / k, (preload[2] - m * g) / (k + ks)]
    np.testing.assert_allclose(u[:3], expected, atol=1e-4 * m * g / k)
    assert u[2] > 0  # on the stop: pushed into it, not given way
    e = out["e"][1:, 3]
    assert np.ptp(e) < 2e-2 * 0.5 * m * 0.3**2


def test_pivot_friction_decays_linearly_and_sticks() -> None:
    # Reference: a pendulum hinged about x (rotational stiffness K = m g d for small angles, inertia I_p) with dry
    # friction torque T at the pivot loses 2 T / K of amplitude every half swing (free vibration with Coulomb
    # friction; the period stays 2 pi sqrt(I_p / K)) and stops for good once the amplitude is below 3 T / K,
    # inside the dead band |theta| <= T / K, with omega exactly 0. World 0 (T = 0) keeps its amplitude.
    # Tolerance: 2 % of the per-swing loss (the small-angle sin theta ~ theta error at theta0 = 0.02 rad is
    # 7e-5 relative; dt = 1e-4 s on a 1.1 s period).
    m, d = 2.0, 0.3
    inertia = np.diag([0.05, 0.045, 0.012])
    theta0 = 0.02
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_rigid_body((0, d * np.sin(theta0), -d * np.cos(theta0)), mass=m, inertia=inertia, blocked="YZ",
                     pivot=(0, 0, 0), name="tool")
    stiff = m * 9.81 * d
    torque = 0.08 * stiff * theta0 / 2  # 8 % of the amplitude lost per half swing
    model, state = b.finalize(DEVICE, n_worlds=2, overrides={"body:tool:pivot_friction": [0.0, torque]})
    sim = wd.Simulation(model, state, dt=1e-4)

    def angle(s: wd.Simulation) -> np.ndarray:
        p = s.state.body_pos.numpy()
        return np.arctan2(p[:, 1], -p[:, 2])

    out = sim.run(150000, record_every=10, observers={"theta": angle,
                                                       "omega": lambda s: s.state.body_angvel.numpy()[:, 0]})
    th = out["theta"]
    swings = np.abs(th[_peaks(np.abs(th[:, 1])), 1])
    swings = swings[swings > 3 * torque / stiff]
    loss = -np.diff(np.concatenate([[theta0], swings]))
    np.testing.assert_allclose(loss, 2 * torque / stiff, rtol=2e-2)
    assert len(swings) >= 10
    assert abs(th[-1, 1]) <= torque / stiff * (1 + 1e-6)
    assert out["omega"][-1, 1] == 0.0 and np.ptp(th[-500:, 1]) < 1e-12
    free = np.abs(th[_peaks(np.abs(th[:, 0])), 0])
    np.testing.assert_allclose(free, theta0, rtol=1e-3)


def test_body_overrides_are_checked() -> None:
    b = wd.ModelBuilder()
    b.add_rigid_body((0, 0, 0), mass=1.0, inertia=np.eye(3), blocked="", name="ball")
    b.add_rigid_body((1, 0, 0), name="wall")
    with pytest.raises(wd.InputError, match="pivot_friction.*not hinged"):
        b.finalize(DEVICE, overrides={"body:ball:pivot_friction": [1.0]})
    with pytest.raises(wd.InputError, match="mass must be positive"):
        b.finalize(DEVICE, overrides={"body:ball:mass": [0.0]})
    with pytest.raises(wd.InputError, match="no mass to scale"):
        b.finalize(DEVICE, overrides={"body:wall:mass": [1.0]})
    with pytest.raises(wd.InputError, match="progressive"):
        b.add_spring("s", 0, (0, 0, 0), 1, (1, 0, 0), stiffness=1.0, progressive=-1.0)


def test_masked_inverse_solves_the_free_rotations() -> None:
    # Reference: numpy's inverse of the matrix with the blocked rows and columns replaced by the identity's, for
    # random symmetric positive-definite matrices and every combination of blocked axes (flag bits 3..5). With one
    # free axis k the inverse is the identity with 1 / m_kk at (k, k), exactly (integrator.masked_inverse takes
    # that path without the general 3 x 3 inverse).
    import warp as wp

    from warpdem.integrator import masked_inverse

    @wp.kernel
    def inv_kernel(mats: wp.array(dtype=wp.mat33d), flags: wp.array(dtype=int), out: wp.array(dtype=wp.mat33d)):
        i = wp.tid()
        out[i] = masked_inverse(mats[i], flags[i])

    rng = np.random.default_rng(4)
    a = rng.normal(size=(40, 3, 3))
    mats = a @ a.transpose(0, 2, 1) + 0.5 * np.eye(3)
    flags = np.arange(40) % 8 * 8
    out = wp.zeros(40, dtype=wp.mat33d, device=DEVICE)
    wp.launch(inv_kernel, 40, inputs=[wp.array(mats, dtype=wp.mat33d, device=DEVICE),
                                      wp.array(flags, dtype=int, device=DEVICE)], outputs=[out], device=DEVICE)
    got = out.numpy()
    for m, f, g in zip(mats, flags, got, strict=True):
        blocked = [(f >> (3 + k)) & 1 for k in range(3)]
        masked = m.copy()
        for k in range(3):
            if blocked[k]:
                masked[k, :] = masked[:, k] = 0.0
                masked[k, k] = 1.0
        np.testing.assert_allclose(g, np.linalg.inv(masked), rtol=1e-12, atol=1e-14)
        if sum(blocked) == 2:
            k = blocked.index(0)
            assert g[k, k] == 1.0 / m[k, k]
