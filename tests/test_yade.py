"""warpdem against Yade 2023.02a reference runs (tests/reference/*.npz), on Warp's CPU backend.

Every scene is rebuilt from the inputs stored in its npz (the single source of truth: materials, geometry, initial
state, dt, engine flags); see tests/reference/README.md and the docstrings of the scripts next to it for the keys
and the recording convention: a record at step s holds positions/velocities after s steps and the contact data and
O.forces computed during step s, which is what warpdem holds right after its s-th ``sim.step()``.

Scene mapping. Yade's facets are independent bodies, so each facet becomes its own one-triangle warpdem mesh (a
static body, numbered like Yade's ids). This matters: within ONE warpdem mesh, a sphere touching the shared edge of
two triangles gets a single contact (a documented deviation from Yade), whereas Yade (and separate meshes) give a
face contact plus an edge contact; the clump (damped run, step 7600) and the packing land on a floor diagonal,
and with one mesh per floor the clump's velocity after that impact differs from Yade's by 9e-3 m/s instead of 2e-5.

Precision facts used in the tolerances (all measured or derived in the comments of each test):
- warpdem stores radii, forces, moments and contact history in float32 (unit round-off EPS32 = 2^-24 ~ 6e-8) and
  positions, velocities and the integration in float64, like Yade's doubles.
- Radii are float64 and overlaps are differences of float64 lengths, as in Yade, so warpdem and Yade see the same
  overlap to float64 round-off (session 1 kept float32 radii, whose rounding shifted every overlap by 4.5e-10 m
  for r = 0.01 m; test_cohesive_pair_normal_force_without_radius_rounding now guards against its return).
- Cundall damping coefficients are float32 too: a free fall under damping lam differs by g*|lam - f32(lam)|*t.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest
from conftest import DEVICE

import warpdem as wd
from warpdem import observers as obs
from warpdem.mass import quat_to_matrix

REF = Path(__file__).resolve().parent / "reference"
EPS32 = 2.0**-24  # float32 unit round-off


# ----------------------------------------------------------------------------------------------------- helpers
@functools.cache
def _npz(name: str) -> dict[str, np.ndarray]:
    with np.load(REF / f"{name}.npz") as f:
        return {k: f[k] for k in f.files}


def _f32(x: float) -> float:
    return float(np.float32(x))


def _ulp32(x: float) -> float:
    return float(np.spacing(np.float32(abs(x))))


def _material(d: dict, prefix: str, **override: object) -> wd.Material:
    """warpdem Material from the npz scalars ``prefix + <name>``. Keys a scene does not store take Yade's
    CohFrictMat defaults (README fact (b)): etaRoll = etaTwist = -1, alphaKr = alphaKtw = 2, fragile = True."""

    def get(key: str, default: object = None) -> object:
        return d[prefix + key].item() if prefix + key in d else default

    cohesive = bool(get("is_cohesive"))
    if prefix + "normal_cohesion" not in d:  # only stored-less for non-cohesive materials, where it never enters
        assert not cohesive and prefix + "shear_cohesion" not in d
    kw = dict(
        young=get("young"),
        poisson=get("poisson"),
        density=get("density"),
        friction_angle=float(np.degrees(get("friction_angle"))),
        normal_cohesion=get("normal_cohesion", 0.0),
        shear_cohesion=get("shear_cohesion", 0.0),
        eta_roll=get("eta_roll", -1.0),
        eta_twist=get("eta_twist", -1.0),
        alpha_kr=get("alpha_kr", 2.0),
        alpha_ktw=get("alpha_ktw", 2.0),
        moment_law=bool(get("moment_rotation_law")),
        fragile=bool(get("fragile", True)),
        cohesive=cohesive,
    )
    kw.update(override)
    return wd.Material(**kw)


def _add_facets(b: wd.ModelBuilder, vertices: np.ndarray, material: str) -> None:
    """One static one-triangle mesh per Yade facet (bodies 0..n-1, like Yade's facet ids)."""
    for j, tri in enumerate(vertices):
        b.add_mesh(f"facet{j}", tri, [[0, 1, 2]], material)


def _entry(lst: object, sphere: int, key: int) -> dict | None:
    """Copy of the history of the candidate-list entry (sphere, key_a == key), or None if not listed."""
    s, c = int(lst.start.numpy()[sphere]), int(lst.count.numpy()[sphere])
    hit = np.nonzero(lst.key_a.numpy()[s : s + c] == key)[0]
    if len(hit) == 0:
        return None
    h = lst.hist.numpy()[s + hit[0] : s + hit[0] + 1].copy()[0]  # .numpy() is a view on the CPU: copy
    return {f: np.array(h[f], dtype=np.float64) for f in ("fs", "mb", "mtw", "normal", "unp", "an", "as_")} | {
        "flags": int(h["flags"])
    }


def _assert_close(name: str, got: np.ndarray, ref: np.ndarray, tol: np.ndarray, steps: np.ndarray) -> float:
    """|got - ref| <= tol per record (tol broadcast over the trailing axes); returns the max error."""
    err = np.abs(np.asarray(got, float) - np.asarray(ref, float))
    err = err.reshape(len(err), -1).max(axis=1)
    tol = np.broadcast_to(np.asarray(tol, float), err.shape)
    bad = np.nonzero(err > tol)[0]
    assert len(bad) == 0, (
        f"{name}: {len(bad)} records out of tolerance, first at step {steps[bad[0]]}: error {err[bad[0]]:.3e} > "
        f"tol {tol[bad[0]]:.3e} (max error {err.max():.3e})"
    )
    return float(err.max()) if len(err) else 0.0


# ================================================================================================ 1. cohesive pair
PAIR_RUNS = ["", "noalways_", "nonfragile_"]


def _pair_sim(fragile: bool, always: bool, unp_max: float) -> wd.Simulation:
    d = _npz("cohesive_pair")
    b = wd.ModelBuilder(gravity=tuple(d["gravity"]))
    b.add_material("m", _material(d, "mat_", fragile=fragile))
    for i in range(2):
        b.add_sphere(
            d["pos0"][i],
            float(d["radius"][i]),
            "m",
            velocity=d["vel0"][i],
            angular_velocity=d["angvel0"][i],
            blocked=str(d["blocked_dofs"]),
        )
    b.set_local_damping("default", float(d["damping"]))
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(
        model,
        state,
        dt=float(d["dt"]),
        always_use_moment_law=always,
        unp_max=unp_max,
        cohesion_on_new_contacts=bool(d["set_cohesion_on_new_contacts"]),
    )
    # Yade: ip2.setCohesionNow before the first step (cohesion_set_iter = 0); the contact is created with cohesion
    # in that step. warpdem's set_cohesion_now() acts in the next step, also on contacts created in it.
    assert bool(d["set_cohesion_now"]) and int(d["cohesion_set_iter"]) == 0
    sim.set_cohesion_now()
    return sim


@functools.cache
def _pair_run(prefix: str, unp_max: float | None = None, stop_at_break: bool = False) -> dict:
    """Run one cohesive_pair variant; per-record arrays plus the per-step event steps (Yade's definitions)."""
    d = _npz("cohesive_pair")
    if unp_max is None:  # the value set on the phys; nan = Yade's default, 0
        u = float(d[prefix + "unp_max"])
        unp_max = 0.0 if np.isnan(u) else u
    # nonfragile_: Yade sets phys.unpMax = -1 after step 1; warpdem's option holds from step 1, which is equivalent
    # because the contact is compressed (no tensile yield) in step 1.
    sim = _pair_sim(bool(d[prefix + "fragile"]), bool(d[prefix + "always_use_moment_law"]), unp_max)
    steps = d[prefix + "step"]
    n_steps = int(d[prefix + "n_steps"]) if not stop_at_break else 10**9
    rec_index = {int(s): i for i, s in enumerate(steps)}
    keys = (
        "f0",
        "t0",
        "f1",
        "t1",
        "pos",
        "quat",
        "exists",
        "cohesive",
        "fs",
        "mb",
        "mtw",
        "normal",
        "unp",
        "an",
        "as_",
    )
    out: dict = {k: [] for k in keys}
    coh_broken = brk = -1
    seen = False
    s = 0
    while s < n_steps:
        sim.step()
        s += 1
        e = _entry(sim.contacts.ss, 0, 1)
        active = e is not None and (e["flags"] & 1) != 0
        if active:
            seen = True
            if not e["flags"] & 2 and coh_broken < 0:
                coh_broken = s
        elif seen and brk < 0:
            brk = s
            if stop_at_break:
                break
        if s in rec_index:
            f, t = sim.data.body_force.numpy().astype(np.float64), sim.data.body_torque.numpy().astype(np.float64)
            out["f0"].append(f[0])
            out["f1"].append(f[1])
            out["t0"].append(t[0])
            out["t1"].append(t[1])
            out["pos"].append(sim.state.body_pos.numpy().copy())
            out["quat"].append(sim.state.body_quat.numpy().copy())
            out["exists"].append(active)
            out["cohesive"].append(active and (e["flags"] & 2) != 0)
            for k in ("fs", "mb", "mtw", "normal"):
                out[k].append(e[k] if active else np.full(3, np.nan))
            for k in ("unp", "an", "as_"):
                out[k].append(float(e[k]) if active else np.nan)
            if s == int(steps[0]):
                ct = obs.contact_table(sim)
                out["table"] = {k: ct[k][ct["kind"] == 0] for k in ("kn", "ks", "kr", "ktw")}
    res = {k: np.asarray(v) for k, v in out.items() if k != "table"}
    res.update(table=out.get("table"), cohesion_broken_step=coh_broken, break_step=brk)
    return res


def _pair_un(s: np.ndarray | int) -> np.ndarray:
    """Yade's overlap used in step s (configuration after s - 1 steps of the prescribed motion), float64 [m]."""
    d = _npz("cohesive_pair")
    t = (np.asarray(s, float) - 1.0)[..., None] * float(d["dt"])
    x0 = d["pos0"][0] + t * d["vel0"][0]
    x1 = d["pos0"][1] + t * d["vel0"][1]
    return d["radius"].sum() - np.linalg.norm(x1 - x0, axis=-1)


def _allowed_steps(step: int, margin_before: float, overshoot_after: float, tol: float) -> set[int]:
    """A threshold crossed by Yade in ``step`` (margin_before: Yade's distance to the threshold one step earlier,
    overshoot_after: how far past it Yade is in ``step``). warpdem may cross one step earlier/later only if that
    distance is within ``tol``, the bound on warpdem's error in the compared quantity."""
    allowed = {step}
    if margin_before < tol:
        allowed.add(step - 1)
    if overshoot_after < tol:
        allowed.add(step + 1)
    return allowed


@pytest.mark.parametrize("prefix", PAIR_RUNS, ids=["main", "noalways", "nonfragile"])
def test_cohesive_pair(prefix: str) -> None:
    # Reference: tests/reference/cohesive_pair.npz (cohesive_pair.py), runs '', 'noalways_', 'nonfragile_'.
    # The motion is prescribed (both spheres have every DoF blocked), so warpdem and Yade see the same geometry at
    # every step and the comparison is tight, record by record. Tolerances:
    # - Fn: 1e-6 of the largest |Fn| (a float32 evaluation of kn*(un - unp): a few round-offs of 2^-24, with
    #   margin); the overlap itself is float64 in both engines (delta = 0 below keeps the formulas general).
    # - Fs, Mb, Mtw are incremental: each step rounds the running float32 value three times (two subtractions
    #   transporting it to the new tangent plane, one adding the increment), half an ulp each, so after s steps
    #   1.5 * s * ulp32(max |value|), plus the Fn error passed on through the caps (tan(phi)*dFn for the Coulomb
    #   limit, maxRollPl*dFn / maxTwistPl*dFn for the moment caps).
    # - body force = -(Fn n + Fs): sum of both; torque = (C - x0) x f0 - M with |C - x0| <= R.
    # - event steps (cohesion breakage, contact deletion) must be Yade's, or one step off only where Yade's own
    #   distance to the threshold in the neighbouring step is smaller than warpdem's error bound (see
    #   _allowed_steps).
    d = _npz("cohesive_pair")
    w = _pair_run(prefix)
    steps = d[prefix + "step"]
    ex_y = d[prefix + "exists"]
    R = float(d["radius"].max())
    delta = 0.0  # float64 radii: no offset of the overlap
    first = np.argmax(ex_y)
    kn, tanphi = float(d[prefix + "kn"][first]), float(d[prefix + "tan_friction"][first])
    roll, twist = float(d[prefix + "max_roll_pl"][first]), float(d[prefix + "max_twist_pl"][first])
    normal_y = d[prefix + "normal"]
    fn_y_vec = d[prefix + "normal_force"]
    fn_y = np.einsum("ij,ij->i", np.nan_to_num(fn_y_vec), np.nan_to_num(normal_y))
    s = steps.astype(float)
    tol_fn = kn * delta + 1e-6 * np.abs(fn_y).max()
    tol_fs = tanphi * tol_fn + 1.5 * s * _ulp32(np.nanmax(np.abs(d[prefix + "shear_force"])))
    tol_mb = roll * tol_fn + 1.5 * s * _ulp32(np.nanmax(np.abs(d[prefix + "moment_bending"])))
    tol_mt = twist * tol_fn + 1.5 * s * _ulp32(np.nanmax(np.abs(d[prefix + "moment_twist"])))

    # ---- contact parameters (Ip2): adhesions a = C min(R)^2, stiffnesses; float32 storage -> 1e-6 relative
    assert w["table"] is not None and len(w["table"]["kn"]) == 1
    for k in ("kn", "ks", "kr", "ktw"):
        assert w["table"][k][0] == pytest.approx(float(d[prefix + k][first]), rel=1e-6), k
    assert w["an"][first] == pytest.approx(float(d[prefix + "normal_adhesion"][first]), rel=1e-6)
    assert w["as_"][first] == pytest.approx(float(d[prefix + "shear_adhesion"][first]), rel=1e-6)

    # ---- event steps
    y_coh, y_brk = int(d[prefix + "cohesion_broken_step"]), int(d[prefix + "break_step"])
    assert (w["cohesion_broken_step"] < 0) == (y_coh < 0)
    if y_coh >= 0:
        # Yade's shear margin a_s + Fn tan(phi) - |Fs| is smooth in time: extrapolate it from the last three
        # pre-breakage records (quadratic; its error here is 2e-8 N, checked against a per-step Yade run) to the
        # step before breakage and to the breaking step.
        pre = np.nonzero(ex_y & (steps < y_coh))[0][-3:]
        margin = (
            d[prefix + "shear_adhesion"][pre]
            + fn_y[pre] * tanphi
            - np.linalg.norm(d[prefix + "shear_force"][pre], axis=1)
        )
        fit = np.polyfit(steps[pre].astype(float), margin, 2)
        m_before, m_at = np.polyval(fit, y_coh - 1.0), np.polyval(fit, float(y_coh))
        assert m_before >= 0 > m_at, "extrapolated Yade margin inconsistent with its breakage step"
        eps = tanphi * tol_fn + 1.5 * y_coh * _ulp32(np.nanmax(np.abs(d[prefix + "shear_force"])))
        allowed = _allowed_steps(y_coh, m_before, -m_at, eps)
        assert w["cohesion_broken_step"] in allowed, (w["cohesion_broken_step"], allowed)
    assert (w["break_step"] < 0) == (y_brk < 0)
    if y_brk >= 0:
        # fragile and cohesion already broken: deleted as soon as un < 0 (Fn < -a_n = 0); un is known exactly from
        # the prescribed motion, warpdem's un differs by delta (+ float32 rounding of un, < 1e-11 m)
        u_before, u_at = float(_pair_un(y_brk - 1)), float(_pair_un(y_brk))
        assert u_before >= 0 > u_at, "Yade's deletion step inconsistent with the prescribed motion"
        allowed = _allowed_steps(y_brk, u_before, -u_at, delta + 1e-11)
        assert w["break_step"] in allowed, (w["break_step"], allowed)

    # ---- per record: existence and cohesion state agree wherever both codes have passed (or not) each event
    def before(step_w: int, step_y: int) -> tuple[np.ndarray, np.ndarray]:
        big = np.iinfo(np.int64).max
        sw = step_w if step_w >= 0 else big
        sy = step_y if step_y >= 0 else big
        return steps < sw, steps < sy

    exw_b, exy_b = before(w["break_step"], y_brk)
    cw_b, cy_b = before(w["cohesion_broken_step"], y_coh)
    same = (exw_b == exy_b) & (cw_b == cy_b)
    assert np.array_equal(w["exists"][same], ex_y[same])
    coh_y = np.where(ex_y, d[prefix + "cohesion_broken"] == 0, False)
    assert np.array_equal(w["cohesive"][same], coh_y[same])
    both = same & ex_y & w["exists"]
    assert both.sum() > 0.8 * ex_y.sum()
    sb = steps[both]

    # stale moments: without always_use_moment_law Yade and warpdem freeze the moments of the last cohesive step,
    # so a one-step shift of the breakage freezes values one step apart: add |shift| x (per-step change of the
    # moment just before breakage, from Yade's last two pre-breakage records)
    extra_mb = extra_mt = 0.0
    if y_coh >= 0 and not bool(d[prefix + "always_use_moment_law"]):
        pre = np.nonzero(ex_y & (steps < y_coh))[0][-2:]
        per = float(steps[pre[1]] - steps[pre[0]])
        shift = abs(w["cohesion_broken_step"] - y_coh)
        extra_mb = shift * np.abs(np.diff(d[prefix + "moment_bending"][pre], axis=0)).max() / per
        extra_mt = shift * np.abs(np.diff(d[prefix + "moment_twist"][pre], axis=0)).max() / per
    stale = steps >= min(w["cohesion_broken_step"], y_coh) if y_coh >= 0 else np.zeros(len(steps), bool)

    errs = {}
    fn_w = -w["f0"] - w["fs"]  # force on body 0 is -(Fn n + Fs)
    errs["Fn"] = _assert_close("normal force", fn_w[both], fn_y_vec[both], tol_fn, sb)
    errs["normal"] = _assert_close("normal", w["normal"][both], normal_y[both], 1e-6, sb)  # float32 unit vector
    errs["Fs"] = _assert_close("shear force", w["fs"][both], d[prefix + "shear_force"][both], tol_fs[both], sb)
    errs["Mb"] = _assert_close(
        "bending moment", w["mb"][both], d[prefix + "moment_bending"][both], tol_mb[both] + extra_mb * stale[both], sb
    )
    errs["Mtw"] = _assert_close(
        "twisting moment", w["mtw"][both], d[prefix + "moment_twist"][both], tol_mt[both] + extra_mt * stale[both], sb
    )
    # forces and torques on the bodies at every record (zero where no contact); the torque includes the moments
    # only where the moment law is applied, so stale moments do not enter it
    sm = same
    tol_f = tol_fn + tol_fs
    tol_t = R * tol_f + tol_mb + tol_mt
    for k, key in (("f0", "force_b0"), ("f1", "force_b1")):
        errs[k] = _assert_close(key, w[k][sm], d[prefix + key][sm], tol_f[sm], steps[sm])
    for k, key in (("t0", "torque_b0"), ("t1", "torque_b1")):
        errs[k] = _assert_close(key, w[k][sm], d[prefix + key][sm], tol_t[sm], steps[sm])
    if prefix == "nonfragile_":
        # plastic normal displacement: unp = un + a_n/kn, un carries the radius offset delta
        # (float32: un and un + a_n/kn each rounded, kn rounded: < 2 ulp; 4 allowed)
        errs["unp"] = _assert_close(
            "unp",
            w["unp"][both],
            d["nonfragile_unp"][both],
            delta + 4 * _ulp32(np.nanmax(np.abs(d["nonfragile_unp"]))),
            sb,
        )
        assert np.nanmin(d["nonfragile_unp"]) < -5e-5  # the run does go deep into tensile plasticity
    # prescribed motion x += v dt (float64, both codes): positions to round-off (<= 2e4 additions of 2^-53
    # relative at 0.03 m: < 1e-13 m; 1e-12 allowed); orientation: q <- dq(|w| dt) q per step in both codes, <= 2e4
    # float64 quaternion products (< 5e-12; 1e-11 allowed; the npz stores (w, x, y, z), warpdem (x, y, z, w))
    errs["pos"] = _assert_close("positions", w["pos"], d[prefix + "pos"], 1e-12, steps)
    q_y = d[prefix + "ori"][..., [1, 2, 3, 0]]
    dq = np.minimum(np.abs(w["quat"] - q_y).max(axis=-1), np.abs(w["quat"] + q_y).max(axis=-1))
    errs["ori"] = _assert_close("orientation", dq, 0.0, 1e-11, steps)
    print(
        f"cohesive_pair[{prefix or 'main'}] events (warpdem/Yade): cohesion broken "
        f"{w['cohesion_broken_step']}/{y_coh}, deleted {w['break_step']}/{y_brk}; max errors "
        + ", ".join(f"{k} {v:.2e}" for k, v in errs.items())
    )


def test_cohesive_pair_normal_force_without_radius_rounding() -> None:
    # Reference: tests/reference/cohesive_pair.npz, main run, with Yade's exact event steps 9614 (cohesion broken)
    # and 10001 (deleted). Allows only float32 ARITHMETIC error on Fn, 1e-6 of max |Fn| (a few round-offs of 2^-24
    # with margin). Regression guard: float32 radii (session 1) shifted every overlap by 4.47e-10 m, gave a
    # 4.47e-5 N offset here (37x this bound) and broke/deleted the bond one step early.
    d = _npz("cohesive_pair")
    w = _pair_run("")
    both = d["exists"] & w["exists"]
    fn_y = d["normal_force"][both]
    err = np.abs(-w["f0"][both] - w["fs"][both] - fn_y).max()
    assert err <= 1e-6 * np.abs(fn_y).max(), f"normal force error {err:.3e} N"
    assert (w["cohesion_broken_step"], w["break_step"]) == (int(d["cohesion_broken_step"]), int(d["break_step"]))


def test_cohesive_pair_nonfragile_default_unp_max() -> None:
    # Reference: cohesive_pair.npz key nonfragile_unpmax0_break_step (non-fragile bond, Yade's default unpMax = 0):
    # deleted at the first tensile yield, i.e. in the first step whose overlap un < -a_n/kn. un is known exactly
    # from the prescribed motion (float64); warpdem's differs by float32 rounding of un (< 1e-11 m), so the step may
    # differ by one only if Yade's un is within that of the threshold in the neighbouring step.
    d = _npz("cohesive_pair")
    y = int(d["nonfragile_unpmax0_break_step"])
    w = _pair_run("nonfragile_", unp_max=0.0, stop_at_break=True)
    first = np.argmax(d["nonfragile_exists"])
    thr = -float(d["nonfragile_normal_adhesion"][first]) / float(d["nonfragile_kn"][first])
    u_before, u_at = float(_pair_un(y - 1)) - thr, float(_pair_un(y)) - thr
    assert u_before >= 0 > u_at, "Yade's deletion step inconsistent with un < -a_n/kn"
    allowed = _allowed_steps(y, u_before, -u_at, 1e-11)
    assert w["cohesion_broken_step"] < 0 and w["break_step"] in allowed, (w["break_step"], allowed)


# ================================================================================================ 2. facet slide
def _slide_run(prefix: str) -> dict:
    d = _npz("facet_slide")
    phi = float(d[prefix + "sphere_friction_angle"])
    b = wd.ModelBuilder(gravity=tuple(d["gravity"]))
    b.add_material("facet", _material(d, "facet_"))
    b.add_material("sphere", _material(d, "sphere_", friction_angle=float(np.degrees(phi))))
    _add_facets(b, d["facet_vertices"], "facet")
    R = float(d["sphere_radius"])
    pos0 = d["sphere_pos0"]  # at exactly R from the plane: zero initial overlap, as the scene specifies
    sid = b.add_sphere(pos0, R, "sphere", velocity=d["sphere_vel0"], blocked=str(d["sphere_blocked_dofs"]))
    assert sid == len(d["facet_vertices"])  # Yade: facets 0, 1, sphere 2
    b.set_local_damping("default", float(d["damping"]))
    model, state = b.finalize(DEVICE)
    assert model.host["body_mass"][sid] == pytest.approx(float(d["sphere_mass"]), rel=1e-12)
    sim = wd.Simulation(
        model,
        state,
        dt=float(d["dt"]),
        cohesion_on_new_contacts=bool(d["set_cohesion_on_new_contacts"]),
        always_use_moment_law=bool(d["always_use_moment_law"]),
    )
    out: dict = {k: [] for k in ("pos", "vel", "force", "exists")}
    s = 0
    for target in d[prefix + "step"]:
        while s < target:
            sim.step()
            s += 1
        out["pos"].append(state.body_pos.numpy()[sid].copy())
        out["vel"].append(state.body_vel.numpy()[sid].copy())
        out["force"].append(sim.data.body_force.numpy()[sid].astype(np.float64))
        ex = []
        for j in range(len(d["facet_vertices"])):
            e = _entry(sim.contacts.st, 0, j)
            ex.append(e is not None and (e["flags"] & 1) != 0)
        out["exists"].append(ex)
        if "table" not in out and any(ex):
            ct = obs.contact_table(sim)
            out["table"] = {k: ct[k][ct["kind"] == 1] for k in ("kn", "ks")}
    return {k: (np.asarray(v) if k != "table" else v) for k, v in out.items()}


@pytest.mark.parametrize("prefix", ["", "stick_"], ids=["slide", "stick"])
def test_facet_slide(prefix: str) -> None:
    # Reference: tests/reference/facet_slide.npz (facet_slide.py), runs '' (phi = 20 deg, slides) and 'stick_'
    # (phi = 35 deg, sticks). Facet-sphere contact: kn = 4/3 E R, ks = nu kn (facet radius 2R).
    # The normal motion is an undamped oscillator (omega_n = sqrt(kn/m), amplitude A = m g cos(theta)/kn, force
    # between 0 and 2 m g cos(theta)): an error in its frequency grows into a phase error omega_n*t*(relative
    # frequency error). float32 rounding of kn gives a relative frequency error < EPS32; we allow 4*EPS32. Hence:
    # - contact force (all components, Yade's O.forces.f): 1e-5 of 2mg cos(theta) (float32 evaluation of n, un,
    #   kn*un, the shear spring: ~10 round-offs of 2^-24, x10 margin) + m g cos(theta) * phase(t);
    # - normal position / velocity: A*phase(t), A*omega_n*phase(t) (+ round-off floors);
    # - along-slope velocity / position: the time integrals of the force tolerance divided by m (the only source of
    #   tangential error is the contact force, bounded at every record by the force tolerance);
    # - contact existence per facet: identical (only facet 0 is ever touched).
    d = _npz("facet_slide")
    w = _slide_run(prefix)
    steps = d[prefix + "step"]
    t = d[prefix + "time"]
    n, e1 = d["plane_normal"], d["plane_e1"]
    m, g, th = float(d["sphere_mass"]), float(np.linalg.norm(d["gravity"])), float(d["theta"])
    kn = float(d[prefix + "kn"][0])
    f_amp = m * g * np.cos(th)
    omega = np.sqrt(kn / m)
    phase = 4 * EPS32 * omega * t
    a, bb = 1e-5 * 2 * f_amp, f_amp * 4 * EPS32 * omega  # tol_F(t) = a + bb t
    tol_f = a + bb * t
    tol_xn = f_amp / kn * phase + 1e-12
    tol_vn = f_amp / kn * omega * phase + a * float(d["dt"]) / m
    tol_vt = (a * t + bb * t**2 / 2) / m
    tol_xt = (a * t**2 / 2 + bb * t**3 / 6) / m

    assert np.array_equal(w["exists"], d[prefix + "contact_exists"])
    assert w["table"]["kn"][0] == pytest.approx(kn, rel=1e-6)
    assert w["table"]["ks"][0] == pytest.approx(float(d[prefix + "ks"][0]), rel=1e-6)
    dx, dv = w["pos"] - d[prefix + "pos"], w["vel"] - d[prefix + "vel"]
    errs = {
        "F": _assert_close("contact force", w["force"], d[prefix + "force"], tol_f, steps),
        "Fn": _assert_close(
            "normal force",
            w["force"] @ n,  # facet 0's contact (Fn = 0 where none)
            np.nan_to_num(np.einsum("ij,ij->i", d[prefix + "normal_force"][:, 0], d[prefix + "contact_normal"][:, 0])),
            tol_f,
            steps,
        ),
        "x_n": _assert_close("normal position", dx @ n, 0.0, tol_xn, steps),
        "v_n": _assert_close("normal velocity", dv @ n, 0.0, tol_vn, steps),
        "x_t": _assert_close("in-plane position", dx - np.outer(dx @ n, n), 0.0, tol_xt, steps),
        "v_t": _assert_close("in-plane velocity", dv - np.outer(dv @ n, n), 0.0, tol_vt, steps),
    }
    disp = (d[prefix + "pos"][-1] - d["sphere_pos0"]) @ e1
    print(
        f"facet_slide[{prefix or 'slide'}] displacement along e1 {disp:.6e} m (Yade), max errors "
        + ", ".join(f"{k} {v:.2e}" for k, v in errs.items())
    )


# ================================================================================================ 3. clump drop
def _clump_build(damping: float) -> tuple[wd.Simulation, int]:
    d = _npz("clump_drop")
    b = wd.ModelBuilder(gravity=tuple(d["gravity"]))
    b.add_material("m", _material(d, ""))
    _add_facets(b, d["facet_vertices"], "m")
    cid = b.add_clump(
        d["member_pos0"],
        d["member_radius"],
        "m",
        velocity=d["clump_vel0"],
        angular_velocity=d["clump_angvel0"],
        group="clump",
    )
    b.set_local_damping("clump", damping)
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(
        model,
        state,
        dt=float(d["dt"]),
        cohesion_on_new_contacts=bool(d["set_cohesion_on_new_contacts"]),
        always_use_moment_law=bool(d["always_use_moment_law"]),
    )
    return sim, cid


def test_clump_mass_and_inertia() -> None:
    # Reference: tests/reference/clump_drop.npz inputs clump_mass, clump_inertia, clump_pos0, clump_ori0,
    # member_local_pos, clump_angmom0 (what Yade's appendClumped produced) and check_* (numpy sum-of-spheres rule).
    # Both codes do the same float64 arithmetic (sum of masses, parallel axes, symmetric eigen-decomposition):
    # mass and centre to 1e-12, principal moments and axes to 1e-9 (eigenvectors are accurate to eps/gap, the gaps
    # are 8 % of the moments). Member offsets are stored in float32 in warpdem: 2 ulp32 of the largest offset.
    d = _npz("clump_drop")
    sim, cid = _clump_build(0.0)
    h = sim.model.host
    assert h["body_mass"][cid] == pytest.approx(float(d["clump_mass"]), rel=1e-12)
    assert h["body_mass"][cid] == pytest.approx(float(d["check_mass_sum"]), rel=1e-12)
    np.testing.assert_allclose(h["body_inertia"][cid], d["clump_inertia"], rtol=1e-9)
    np.testing.assert_allclose(np.sort(h["body_inertia"][cid]), d["check_inertia_principal"], rtol=1e-9)
    state = sim.state.numpy()
    np.testing.assert_allclose(
        state["body_pos"][cid], d["clump_pos0"], rtol=0, atol=1e-12 * np.abs(d["member_pos0"]).max()
    )
    rot_w = quat_to_matrix(state["body_quat"][cid])
    q = d["clump_ori0"]
    rot_y = quat_to_matrix(np.r_[q[1:], q[0]])
    # same principal frame up to the (arbitrary) sign of each axis
    np.testing.assert_allclose(np.abs(rot_w.T @ rot_y), np.eye(3), rtol=0, atol=1e-9)
    world_i = rot_w @ np.diag(h["body_inertia"][cid]) @ rot_w.T
    np.testing.assert_allclose(
        world_i, rot_y @ np.diag(d["clump_inertia"]) @ rot_y.T, rtol=0, atol=1e-9 * d["clump_inertia"].max()
    )
    off_w = sim.data.sphere_arm.numpy().astype(np.float64)  # member offsets R p_i in the world frame
    off_y = d["member_local_pos"] @ rot_y.T
    tol = 2 * _ulp32(np.abs(off_y).max())
    np.testing.assert_allclose(off_w, off_y, rtol=0, atol=tol)
    np.testing.assert_allclose(sim.data.sphere_pos.numpy(), d["member_pos0"], rtol=0, atol=tol)
    np.testing.assert_allclose(
        state["body_angmom"][cid], d["clump_angmom0"], rtol=1e-12, atol=1e-12 * np.abs(d["clump_angmom0"]).max()
    )


@functools.cache
def _clump_run(prefix: str) -> dict:
    d = _npz("clump_drop")
    sim, cid = _clump_build(float(d["damping"] if prefix == "" else d["damped_damping"]))
    out: dict = {k: [] for k in ("pos", "vel", "angvel", "angmom", "member_pos", "n_contacts", "ke")}
    s = 0
    for target in d[prefix + "step"]:
        while s < target:
            sim.step()
            s += 1
        st = sim.state.numpy()
        for k, key in (("pos", "body_pos"), ("vel", "body_vel"), ("angvel", "body_angvel"), ("angmom", "body_angmom")):
            out[k].append(st[key][cid].copy())
        out["member_pos"].append(sim.data.sphere_pos.numpy().copy())
        out["n_contacts"].append(int(obs.contact_count(sim)[0].sum()))
        out["ke"].append(float(obs.kinetic_energy(sim)[0]))
    return {k: np.asarray(v) for k, v in out.items()}


def _impact_records(angmom0: np.ndarray, angmom: np.ndarray) -> np.ndarray:
    """Records during whose 100 steps a contact acted: the angular momentum about the centre of mass changes
    only through contact torques (gravity exerts none, local damping scales torques only)."""
    L = np.vstack([angmom0, angmom])
    return np.linalg.norm(np.diff(L, axis=0), axis=1) > 1e-9 * np.linalg.norm(L[:-1], axis=1)


@pytest.mark.parametrize("prefix", ["", "damped_"], ids=["undamped", "damped"])
def test_clump_drop(prefix: str) -> None:
    # Reference: tests/reference/clump_drop.npz (clump_drop.py), runs '' (no damping) and 'damped_' (0.3).
    # Phases are taken from Yade's data: the records where the angular momentum changes are impacts.
    # Phase 0, free flight before the first impact: float64 leapfrog + Yade's aspherical (Fincham) rotation in
    #   both codes: angular velocity to 1e-12 relative; the only difference is the float32 damping coefficient,
    #   |a - a_Yade| = g |lam - f32(lam)|, so |dv| <= 2 g dlam t and |dx| <= g dlam t^2 (2x the exact values);
    #   member positions add the float32 member offsets (2 ulp32).
    # Phase 1, first impact until the second one starts: float32 contact forces (relative ~1e-6) make the impulse
    #   wrong by ~1e-6: velocity, angular velocity and angular momentum to 1e-5 of their change across the
    #   impact, and positions to (that velocity tolerance) x (time since the impact) on top of phase 0's.
    # Phase 2, the rest (4 more impacts undamped; >30 impacts and rocking damped): every impact of the spinning
    #   clump amplifies the error (x10-100 per impact observed) and the damped run's Cundall sign switches are
    #   discontinuous, so only looser agreement is meaningful: the impact records must coincide (+-1 record),
    #   positions (centre and members) agree to 1 % of the smallest member radius, velocities and spins of the
    #   records in flight to 1 % of the run's largest speed / spin (a wrong restitution, friction, inertia or
    #   damping law gives 10-100 % differences), and the kinetic energy averaged over each half of phase 2 to 1 %.
    #   Velocities of mid-impact records are not compared pointwise: there the clump accelerates at ~1e3 m/s^2 and
    #   ~4e4 rad/s^2 (0.03 m/s and 0.8 rad/s per step), so a sub-step shift of the contact onset moves them far more.
    d = _npz("clump_drop")
    w = _clump_run(prefix)
    steps = d[prefix + "step"]
    t = d[prefix + "time"]
    g = float(np.linalg.norm(d["gravity"]))
    lam = float(d["damping"] if prefix == "" else d["damped_damping"])
    dlam = abs(lam - _f32(lam))
    member_tol = 2 * _ulp32(np.abs(d["member_local_pos"]).max())

    imp_y = _impact_records(d["clump_angmom0"], d[prefix + "angmom"])
    imp_w = _impact_records(d["clump_angmom0"], w["angmom"])
    k1 = int(np.argmax(imp_y))
    k2 = k1 + int(np.argmax(~imp_y[k1:]))  # end of the first impact episode
    k2 = k2 + int(np.argmax(imp_y[k2:]))  # start of the second
    assert 0 < k1 < k2 < len(steps)
    errs = {}

    # phase 0
    p0 = slice(0, k1)
    tol_x0 = g * dlam * t**2 + 1e-12
    tol_v0 = 2 * g * dlam * t + 1e-12
    errs["free pos"] = _assert_close("free flight position", w["pos"][p0], d[prefix + "pos"][p0], tol_x0[p0], steps[p0])
    errs["free vel"] = _assert_close("free flight velocity", w["vel"][p0], d[prefix + "vel"][p0], tol_v0[p0], steps[p0])
    w_scale = np.abs(d[prefix + "angvel"][p0]).max()
    errs["free angvel"] = _assert_close(
        "free flight angular velocity", w["angvel"][p0], d[prefix + "angvel"][p0], 1e-12 * w_scale, steps[p0]
    )
    errs["free members"] = _assert_close(
        "free flight member positions",
        w["member_pos"][p0],
        d[prefix + "member_pos"][p0],
        tol_x0[p0] + member_tol,
        steps[p0],
    )

    # phase 1
    p1 = slice(k1, k2)
    episode = slice(k1, k1 + int(np.argmax(~imp_y[k1:])))
    dv_imp = np.abs(d[prefix + "vel"][episode] - d[prefix + "vel"][k1 - 1]).max()
    dw_imp = np.abs(d[prefix + "angvel"][episode] - d[prefix + "angvel"][k1 - 1]).max()
    dl_imp = np.abs(d[prefix + "angmom"][episode] - d[prefix + "angmom"][k1 - 1]).max()
    tol_v1 = tol_v0 + 1e-5 * dv_imp
    tol_x1 = tol_x0 + 1e-5 * dv_imp * (t - t[k1 - 1])
    errs["impact1 vel"] = _assert_close(
        "velocity after impact 1", w["vel"][p1], d[prefix + "vel"][p1], tol_v1[p1], steps[p1]
    )
    errs["impact1 angvel"] = _assert_close(
        "angular velocity after impact 1", w["angvel"][p1], d[prefix + "angvel"][p1], 1e-5 * dw_imp, steps[p1]
    )
    errs["impact1 angmom"] = _assert_close(
        "angular momentum after impact 1", w["angmom"][p1], d[prefix + "angmom"][p1], 1e-5 * dl_imp, steps[p1]
    )
    errs["impact1 pos"] = _assert_close(
        "position after impact 1", w["pos"][p1], d[prefix + "pos"][p1], tol_x1[p1], steps[p1]
    )
    errs["impact1 members"] = _assert_close(
        "member positions after impact 1",
        w["member_pos"][p1],
        d[prefix + "member_pos"][p1],
        tol_x1[p1] + member_tol,
        steps[p1],
    )

    # phase 2
    p2 = np.arange(k2, len(steps))
    only_y, only_w = (
        set(np.nonzero(imp_y)[0]) - set(np.nonzero(imp_w)[0]),
        set(np.nonzero(imp_w)[0]) - set(np.nonzero(imp_y)[0]),
    )
    for a, other in ((only_y, imp_w), (only_w, imp_y)):
        for k in a:
            assert other[max(k - 1, 0) : k + 2].any(), f"impact around step {steps[k]} in only one code"
    flight = p2[(d[prefix + "n_interactions"][p2] == 0) & (w["n_contacts"][p2] == 0)]
    pos_tol = 0.01 * d["member_radius"].min()
    errs["late pos"] = _assert_close("late positions", w["pos"][p2], d[prefix + "pos"][p2], pos_tol, steps[p2])
    errs["late members"] = _assert_close(
        "late member positions", w["member_pos"][p2], d[prefix + "member_pos"][p2], pos_tol, steps[p2]
    )
    errs["late vel"] = _assert_close(
        "late velocity (in flight)",
        w["vel"][flight],
        d[prefix + "vel"][flight],
        0.01 * np.abs(d[prefix + "vel"]).max(),
        steps[flight],
    )
    errs["late angvel"] = _assert_close(
        "late angular velocity (in flight)",
        w["angvel"][flight],
        d[prefix + "angvel"][flight],
        0.01 * np.abs(d[prefix + "angvel"]).max(),
        steps[flight],
    )
    for half in np.array_split(p2, 2):
        ke_y, ke_w = d[prefix + "kinetic_energy"][half].mean(), w["ke"][half].mean()
        assert ke_w == pytest.approx(ke_y, rel=0.01), (steps[half[0]], ke_w, ke_y)
    print(
        f"clump_drop[{prefix or 'undamped'}] impacts at records {np.nonzero(imp_y)[0].tolist()}, max errors "
        + ", ".join(f"{k} {v:.2e}" for k, v in errs.items())
    )


# ================================================================================================ 4. cohesive packing
@functools.cache
def _packing_run(jitter: float = 0.0, seed: int = 0) -> dict:
    """warpdem's run of cohesive_packing; ``jitter`` [m] displaces the initial centres randomly (ensemble runs)."""
    d = _npz("cohesive_packing")
    b = wd.ModelBuilder(gravity=tuple(d["gravity"]))
    b.add_material("facet", _material(d, "facet_"))
    b.add_material("sphere", _material(d, "sphere_"))
    _add_facets(b, d["facet_vertices"], "facet")
    pos0 = d["pos0"] + np.random.default_rng(seed).uniform(-jitter, jitter, d["pos0"].shape)
    ids = b.add_spheres(pos0, d["radius"], "sphere", velocities=d["vel0"], group="spheres")
    assert ids[0] == int(d["first_sphere_id"])  # facets 0..9, spheres 10..49, as in Yade
    b.set_local_damping("spheres", float(d["damping"]))
    model, state = b.finalize(DEVICE)
    np.testing.assert_allclose(model.host["body_mass"][ids], d["sphere_mass"], rtol=1e-12)
    sim = wd.Simulation(
        model,
        state,
        dt=float(d["dt"]),
        cohesion_on_new_contacts=bool(d["set_cohesion_on_new_contacts"]),
        always_use_moment_law=bool(d["always_use_moment_law"]),
    )
    if bool(d["set_cohesion_now"]):
        sim.set_cohesion_now()
    floor = [int(j) for j in d["floor_facet_ids"]]
    out: dict = {k: [] for k in ("pos", "vel", "n_ss", "n_sf", "n_coh", "z_ss", "ke", "floor")}
    z_ss = obs.coordination_number("spheres")
    s = 0
    for target in d["step"]:
        while s < target:
            sim.step()
            s += 1
        st = sim.state.numpy()
        out["pos"].append(st["body_pos"][ids].copy())
        out["vel"].append(st["body_vel"][ids].copy())
        cc = obs.contact_count(sim)[0]
        out["n_ss"].append(int(cc[0]))
        out["n_sf"].append(int(cc[1]))
        ss = sim.contacts.ss.numpy()
        rows = [np.arange(a, a + c) for a, c in zip(ss["start"], ss["count"], strict=True)]
        idx = np.concatenate(rows).astype(np.int64)
        out["n_coh"].append(int(((ss["hist"]["flags"][idx] & 3) == 3).sum()))  # active and cohesive
        out["z_ss"].append(float(z_ss(sim)[0]))
        out["ke"].append(float(obs.kinetic_energy(sim)[0]))
        # floor facets lie in z = 0 with normal +z: the sum of their contacts' normal forces is -F_z on them (edge
        # contacts on the floor are tilted by < 0.05 rad, cos > 0.999; shear forces are horizontal)
        out["floor"].append(-float(sim.data.mesh_force.numpy()[floor, 2].sum()))
    return {k: np.asarray(v) for k, v in out.items()}


def test_cohesive_packing() -> None:
    # Reference: tests/reference/cohesive_packing.npz (cohesive_packing.py): 40 cohesive spheres settling in a
    # facet box with local damping 0.4.
    # Short horizon (strict): until Yade's first sphere-sphere contact (step 7400) the spheres fall and the bottom
    #   layer bounces on the floor. Free fall differs only by the float32 damping coefficient (|dx| <= g dlam t^2);
    #   the floor impacts add float32 force errors, discontinuously amplified by Cundall damping's sign switches:
    #   velocities to 1e-4 of the largest speed (x10 over the 1e-5 used for a single clump impact, for 16 impacts)
    #   and positions to that times the time since the first floor contact; kinetic energy to 2e-4 relative.
    # Long horizon (statistical): contacts between damped, cohesive, rolling-resisting spheres make the packing
    #   chaotic (the per-sphere difference reaches mm by step 12000), so we compare aggregate quantities:
    #   - contact counts (n_ss, cohesive bonds, n_sf), coordination Z = (2 n_ss + n_sf)/n and Z_ss = 2 n_ss/n
    #     (warpdem's coordination_number observer), averaged over the third and over the last quarter of the run:
    #     difference within 2 sqrt(2) standard deviations of Yade's own record-to-record fluctuation sigma in that
    #     window (at least one contact, or 2/n in Z). These window means are random across realizations: five
    #     warpdem runs whose initial centres differ by 1e-9 m gave last-quarter n_ss means of 33.8-36.9 (Yade 33.1,
    #     its sigma 2.5), and a CUDA run (float32 atomics summed in another order: another realization) gave 37.3
    #     cohesive bonds against Yade's 32.1 (sigma 2.5). Yade's record and ours are two independent realizations,
    #     each uncertain by about sigma, so their difference has a spread of sqrt(2) sigma: two of those;
    #   - kinetic energy: geometric mean over the same windows within one standard deviation of log(KE_Yade) there;
    #   - floor reaction: median over the last half within 3 MADs of Yade's (a spiky signal, hence robust
    #     statistics), and between 0.8 and 1.05 of the weight (the walls carry part of it by friction: 0.92 in Yade);
    #   - final state (time-averaged over the last 20 records): mean height and 10/50/90 % height quantiles within
    #     0.1 mean radius; per-sphere final position: median over spheres of the distance within 0.25 mean radius
    #     (a sphere settled into a different site is off by ~2 radii; a few of those are expected).
    d = _npz("cohesive_packing")
    w = _packing_run()
    steps, t = d["step"], d["time"]
    n = len(d["radius"])
    g = float(np.linalg.norm(d["gravity"]))
    dlam = abs(float(d["damping"]) - _f32(float(d["damping"])))
    errs = {}

    # ---- short horizon
    # until the first impact all spheres fall with one common velocity (same damped gravity): the first record
    # where a sphere's velocity leaves the common one follows the first floor contact (npz velocities are float32)
    k_ss = int(np.argmax(d["n_ss"] > 0))
    spread = np.abs(d["vel"] - np.median(d["vel"], axis=1, keepdims=True)).max(axis=(1, 2))
    k_sf = int(np.argmax(spread > 1e-6))
    assert 0 < k_sf <= int(np.argmax(d["n_sf"] > 0)) < k_ss
    early = slice(0, k_ss)
    v_scale = np.abs(d["vel"][early]).max()
    tol_v = 2 * g * dlam * t + 1e-4 * v_scale * (t >= t[k_sf - 1]) + 1e-12
    tol_x = g * dlam * t**2 + 1e-4 * v_scale * np.maximum(t - t[k_sf - 1], 0.0) + 1e-12
    errs["early pos"] = _assert_close("early positions", w["pos"][early], d["pos"][early], tol_x[early], steps[early])
    errs["early vel"] = _assert_close(
        "early velocities", w["vel"][early], d["vel"][early], tol_v[early] + 2 * _ulp32(v_scale), steps[early]
    )  # npz velocities are f32
    errs["early KE"] = _assert_close(
        "early kinetic energy", w["ke"][early] / d["kinetic_energy"][early], 1.0, 2e-4, steps[early]
    )
    for k in ("n_ss", "n_sf"):
        assert np.array_equal(w[k][early], d[k][early]), k
    np.testing.assert_allclose(w["z_ss"], 2.0 * w["n_ss"] / n)  # the observer counts like Yade's coordination_ss

    # ---- long horizon
    # CPU only. On the CPU a run is deterministic, so this compares one fixed realization with Yade's. On CUDA the
    # float32 atomic sums are ordered differently in every run, so every run is a new realization: one H200 run had
    # 37.3 cohesive bonds (Yade 32.1), the next settled completely by step 30000 (KE 8e-6 J against Yade's
    # still-moving 3e-5 J). A single realization against a single realization can fail any fixed bound; the CUDA
    # check of this statistic needs an ensemble of runs (not done yet: named in the issue notes).
    if DEVICE != "cpu":
        return
    z_w = (2 * w["n_ss"] + w["n_sf"]) / n
    series = {
        "n_ss": (w["n_ss"], d["n_ss"], 1.0),
        "cohesive bonds": (w["n_coh"], d["n_ss_cohesive"], 1.0),
        "n_sf": (w["n_sf"], d["n_sf"], 1.0),
        "Z": (z_w, d["coordination"], 2.0 / n),
        "Z_ss": (w["z_ss"], d["coordination_ss"], 2.0 / n),
    }
    quarter = len(steps) // 4
    windows = [slice(2 * quarter, 3 * quarter), slice(3 * quarter, len(steps))]
    for name, (sw, sy, floor_tol) in series.items():
        for win in windows:
            diff = abs(sw[win].mean() - sy[win].mean())
            tol = max(2.0 * np.sqrt(2.0) * sy[win].std(), floor_tol)
            assert diff <= tol, (
                f"{name} over steps {steps[win][0]}-{steps[win][-1]}: {sw[win].mean():.3f} vs "
                f"{sy[win].mean():.3f} (tol {tol:.3f})"
            )
            errs[f"{name} {steps[win][0]}"] = diff
    for win in windows:
        lw, ly = np.log(w["ke"][win]), np.log(d["kinetic_energy"][win])
        assert abs(lw.mean() - ly.mean()) <= ly.std(), (steps[win][0], np.exp(lw.mean()), np.exp(ly.mean()))
        errs[f"log KE {steps[win][0]}"] = abs(lw.mean() - ly.mean())
    last_half = slice(len(steps) // 2, len(steps))
    fy, fw = d["floor_normal_force"][last_half], w["floor"][last_half]
    mad = np.median(np.abs(fy - np.median(fy)))
    assert abs(np.median(fw) - np.median(fy)) <= 3 * mad, (np.median(fw), np.median(fy), mad)
    assert 0.8 < np.median(fw) / float(d["total_weight"]) <= 1.05
    errs["floor median"] = abs(np.median(fw) - np.median(fy))
    r = float(d["radius"].mean())
    zy, zw = d["pos"][-20:, :, 2].mean(axis=0), w["pos"][-20:, :, 2].mean(axis=0)
    assert abs(zw.mean() - zy.mean()) <= 0.1 * r
    np.testing.assert_allclose(np.percentile(zw, [10, 50, 90]), np.percentile(zy, [10, 50, 90]), rtol=0, atol=0.1 * r)
    dist = np.linalg.norm(w["pos"][-20:].mean(axis=0) - d["pos"][-20:].mean(axis=0), axis=1)
    assert np.median(dist) <= 0.25 * r, np.median(dist)
    errs["mean height"] = abs(zw.mean() - zy.mean())
    errs["median sphere distance"] = float(np.median(dist))
    print("cohesive_packing: " + ", ".join(f"{k} {v:.2e}" for k, v in errs.items()))
