"""The sweep tool of the reference study: the paper's inertia data (sign convention, parallel axes), the parametric
geometry measured from its meshes, STL round trip, and the tool as a warpdem body."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from conftest import DEVICE, point_triangle_distance

import warpdem as wd
from scenes.sweep import (
    PAPER_COM_CAD,
    PAPER_MASS,
    PAPER_PRODUCTS_CAD,
    SweepParams,
    add_sweep,
    build_sweep,
    inertia_about_com,
    inertia_about_point,
    load_sweep,
    paper_inertia_about_com,
    printed_to_tensor,
)
from warpdem.errors import InputError
from warpdem.mass import principal_axes, quat_to_matrix
from warpdem.model import ALL_DOFS, FLAG_PIVOT, dof_mask

STEEL = wd.Material(young=1e9, poisson=0.3, density=10865.5, friction_angle=40.0)
#: exact geometric identities are checked to this [m]: the coordinates (~0.6 m) carry float64 rounding ~1e-16
GEOM_TOL = 1e-9


@pytest.fixture(scope="module")
def tool():
    return build_sweep()


# ------------------------------------------------------------------------------------------- paper's inertia
def test_products_convention_gives_symmetric_positive_definite_com_tensor() -> None:
    # Reference: paper eq. (1)-(2) read as SolidWorks products P_ij = +int x_i x_j dm about the CAD origin;
    # P_ij(com) = P_ij(O) - m c_i c_j. A sweep is nearly symmetric about its mid-plane x = const, so the products
    # involving x vanish about the COM up to the CAD model's asymmetry: |P_xy|, |P_xz| < 3e-3 kg m^2 (1.4e-4 and
    # 2.3e-3 here, against printed values of 1.9e-2 and 8.3e-3 about the origin).
    i_com = paper_inertia_about_com()
    p_com = -i_com  # off the diagonal, the products are minus the tensor's entries
    assert abs(p_com[0, 1]) < 3e-3 and abs(p_com[0, 2]) < 3e-3
    assert np.allclose(i_com, i_com.T, rtol=0, atol=0)
    moments = np.linalg.eigvalsh(i_com)
    assert moments.min() > 0
    assert moments[0] + moments[1] >= moments[2]  # triangle inequality of a real body
    # the parallel-axis step by hand for one diagonal and one off-diagonal entry (reference: I_ii(c) = I_ii(O) -
    # m (|c|^2 - c_i^2), I_yz(c) = -(P_yz(O) - m c_y c_z)); pure arithmetic, so 1e-12
    m, c = PAPER_MASS, PAPER_COM_CAD
    assert i_com[0, 0] == pytest.approx(2.6007 - m * (c[1] ** 2 + c[2] ** 2), abs=1e-12)
    assert i_com[1, 2] == pytest.approx(-(1.0619 - m * c[1] * c[2]), abs=1e-12)


def test_round_trip_com_to_origin_gives_printed_tensor() -> None:
    # Reference: the parallel-axis theorem is exact both ways; moving the COM tensor back to the CAD origin must
    # give diag(printed) - offdiag(printed). Tolerance 1e-12 kg m^2: a few float64 roundings of ~2.6 kg m^2 values.
    back = inertia_about_point(paper_inertia_about_com(), PAPER_MASS, PAPER_COM_CAD, np.zeros(3))
    expected = printed_to_tensor(PAPER_PRODUCTS_CAD, convention="products")
    assert np.allclose(back, expected, rtol=0, atol=1e-12)
    assert expected[1, 2] == -1.0619 and expected[0, 0] == 2.6007


def test_tensor_convention_is_not_physical_about_the_com() -> None:
    # Reference: a real inertia tensor is positive definite about every point. Reading eq. (1) as tensor components
    # gives a matrix that is positive definite about the CAD origin (I_yy I_zz > I_yz^2 there: 1.374 > 1.128) but
    # NOT about the COM: I_yy I_zz = 0.0056 < I_yz^2 = 4.36 there, so that reading is rejected.
    at_origin = printed_to_tensor(PAPER_PRODUCTS_CAD, convention="tensor")
    assert np.linalg.eigvalsh(at_origin).min() > 0
    i_com = inertia_about_com(PAPER_PRODUCTS_CAD, PAPER_MASS, PAPER_COM_CAD, convention="tensor")
    assert i_com[1, 1] * i_com[2, 2] < i_com[1, 2] ** 2
    assert np.linalg.eigvalsh(i_com).min() < 0
    with pytest.raises(InputError, match="inertia"):
        principal_axes(i_com)
    # the x products about the COM are then not small either (|P_xy| = 0.039): no mid-plane symmetry
    assert abs(i_com[0, 1]) > 3e-2


def test_inertia_about_point_matches_point_masses() -> None:
    # Reference: direct sums I = sum m (|r|^2 1 - r r^T) of random point masses about two points. Tolerance 1e-12:
    # float64 sums of O(1) terms.
    rng = np.random.default_rng(3)
    pts, ms = rng.normal(size=(7, 3)), rng.uniform(0.5, 2.0, 7)

    def direct(about: np.ndarray) -> np.ndarray:
        r = pts - about
        return sum(mi * (ri @ ri * np.eye(3) - np.outer(ri, ri)) for mi, ri in zip(ms, r, strict=True))

    m, com, point = ms.sum(), (ms[:, None] * pts).sum(0) / ms.sum(), np.array([0.3, -1.0, 2.0])
    assert np.allclose(inertia_about_point(direct(com), m, com, point), direct(point), rtol=0, atol=1e-12)


def test_bad_convention_is_named() -> None:
    with pytest.raises(InputError, match="convention.*'solidworks'"):
        inertia_about_com(PAPER_PRODUCTS_CAD, PAPER_MASS, PAPER_COM_CAD, convention="solidworks")


# -------------------------------------------------------------------------------------------------- geometry
def _normals(mesh) -> np.ndarray:
    tm = mesh.to_trimesh()
    return np.asarray(tm.face_normals)


def test_blade_width_attack_and_sweep_angles(tool) -> None:
    # Reference: paper section 2.1.2 (width 300 mm, attack angle 20 deg) and SweepParams.sweep_angle (40 deg).
    v = tool.lower.vertices
    assert v[:, 0].max() - v[:, 0].min() == pytest.approx(0.300, abs=GEOM_TOL)
    # blade top faces: upward normals that are not vertical (the shank's top at the split is horizontal)
    n = _normals(tool.lower)
    top = n[(n[:, 2] > 0) & (n[:, 2] < 1 - 1e-9)]
    assert len(top) == 4  # the chevron's top: two wings, two triangles each
    angles = np.degrees(np.arccos(np.clip(top[:, 2], -1, 1)))
    # tolerance 1e-6 deg: arccos near 20 deg amplifies float64 normal noise (~1e-16) to ~1e-14 rad
    assert np.allclose(angles, 20.0, rtol=0, atol=1e-6)
    assert np.all(top[:, 1] > 0)  # normal tilted forward: the surface rises toward the rear (-y), soil climbs it
    assert np.allclose(top[:, 0], 0.0, atol=1e-12)  # no lateral tilt
    # plan-view sweep-back of the leading edge: from the tip to the wing's front corner
    right = v[np.isclose(v[:, 0], v[:, 0].max(), atol=GEOM_TOL)]  # the right wing's end, x = +0.15 m
    corner = right[np.argmax(right[:, 1])]  # its front (leading) corner
    sweep = math.degrees(math.atan2(corner[0] - tool.tip[0], tool.tip[1] - corner[1]))
    assert sweep == pytest.approx(40.0, abs=1e-9)


def test_halves_are_closed_solids(tool) -> None:
    # Reference: a closed, consistently wound mesh has every edge in exactly two faces and a positive volume.
    for mesh in (tool.lower, tool.upper):
        tm = mesh.to_trimesh(process=True)
        assert tm.is_watertight and tm.is_winding_consistent
        assert tm.volume > 0
    # the blade and the lower shank are separate closed components resting on each other (no overlap)
    assert len(tool.lower.to_trimesh(process=True).split(only_watertight=True)) == 2


def test_split_plane_pivot_tip_and_soil_surface(tool) -> None:
    # Reference: SweepParams docstring (split midway between the spring point and the blade top, pivot at the
    # shank's top end on its axis, tip = lowest and most forward point, tip 0.150 m below the soil surface).
    lo, up = tool.lower.vertices, tool.upper.vertices
    assert lo[:, 2].max() == up[:, 2].min() == tool.split_height
    p = tool.params
    blade_top = tool.tip[2] + p.blade_height()
    assert tool.split_height == pytest.approx(0.5 * (tool.sensor_point[2] + blade_top), abs=GEOM_TOL)
    # the blade lies wholly below the split: only the shank reaches it
    assert blade_top < tool.split_height - 0.1
    assert up[:, 2].max() == pytest.approx(tool.pivot[2], abs=GEOM_TOL)
    top_face = up[np.isclose(up[:, 2], up[:, 2].max(), atol=GEOM_TOL)]
    assert np.allclose(top_face[:, :2].mean(axis=0), tool.pivot[:2], atol=GEOM_TOL)
    assert tool.tip[2] == lo[:, 2].min() and tool.tip[1] == lo[:, 1].max()
    assert tool.pivot[2] - tool.tip[2] == pytest.approx(0.600, abs=GEOM_TOL)
    # the soil only touches the lower half: the surface (tip + 0.150 m) lies below the split, pivot well above
    assert tool.soil_surface_z == pytest.approx(tool.tip[2] + 0.150, abs=GEOM_TOL)
    assert tool.split_height > tool.soil_surface_z + 0.1
    assert tool.pivot[2] - tool.soil_surface_z == pytest.approx(0.45, abs=GEOM_TOL)


def test_sensor_point_on_rear_face(tool) -> None:
    # Reference: paper section 2.1.2, the sensor 100 mm from the rotation centre, measured along the shank axis
    # (the lever arm of a y-directed spring force); the springs push from behind, along +y.
    s, up = tool.sensor_point, tool.upper.to_trimesh()
    assert tool.pivot[2] - s[2] == pytest.approx(0.100, abs=GEOM_TOL)
    assert s[1] == pytest.approx(up.vertices[:, 1].min(), abs=GEOM_TOL)  # the rear face y = -shank_depth/2
    tri = np.asarray(up.triangles)
    dist = point_triangle_distance(s[None], tri[:, 0], tri[:, 1], tri[:, 2])
    on = dist < GEOM_TOL  # the point lies on these faces (the rear face's two triangles, or their shared edge)
    assert on.any()
    assert np.allclose(up.face_normals[on], [0.0, -1.0, 0.0], atol=1e-12)  # outward normal of the rear face
    assert np.allclose(tool.spring_direction, [0.0, 1.0, 0.0])
    # straight-line distance, for the record: sqrt(0.1^2 + 0.02^2)
    assert np.linalg.norm(s - tool.pivot) == pytest.approx(math.hypot(0.100, 0.020), abs=GEOM_TOL)


def test_mass_properties_and_placement(tool) -> None:
    # Reference: COM = volume centroid of both halves (trimesh), mass and inertia from the paper; moving the tool
    # translates every point and keeps the inertia. Tolerances: float64 rounding of sums over ~40 faces.
    whole = trimesh.util.concatenate([tool.lower.to_trimesh(), tool.upper.to_trimesh()])
    assert np.allclose(tool.com, whole.center_mass, rtol=0, atol=1e-12)
    assert abs(tool.com[0] - tool.pivot[0]) < 1e-12  # mid-plane symmetry
    assert tool.mass == PAPER_MASS and np.array_equal(tool.inertia, paper_inertia_about_com())
    i_pivot = tool.inertia_about(tool.pivot)
    d = tool.com - tool.pivot
    assert i_pivot[0, 0] == pytest.approx(tool.inertia[0, 0] + PAPER_MASS * (d[1] ** 2 + d[2] ** 2), abs=1e-12)
    off = np.array([0.2, 0.5, 0.7])
    moved = tool.moved(off)
    other = build_sweep(pivot=off)
    for a, b in ((moved.lower.vertices, other.lower.vertices), (moved.upper.vertices, other.upper.vertices),
                 (moved.pivot, other.pivot), (moved.sensor_point, other.sensor_point), (moved.tip, other.tip),
                 (moved.com, other.com)):
        assert np.allclose(a, b, rtol=0, atol=GEOM_TOL)
    assert moved.split_height == pytest.approx(other.split_height, abs=GEOM_TOL)
    assert np.allclose(moved.inertia_about(moved.pivot), i_pivot, rtol=0, atol=1e-12)


def test_params_are_validated() -> None:
    with pytest.raises(InputError, match="attack_angle"):
        SweepParams(attack_angle=95.0)
    with pytest.raises(InputError, match="shank_depth"):
        SweepParams(wing_chord=0.03)
    with pytest.raises(InputError, match="split_below_pivot.*0.05"):
        SweepParams(split_below_pivot=0.05)
    custom = build_sweep(SweepParams(split_below_pivot=0.2))
    assert custom.split_height == pytest.approx(-0.2, abs=GEOM_TOL)


# --------------------------------------------------------------------------------------------------- STL I/O
def test_stl_round_trip(tool, tmp_path) -> None:
    # Reference: binary STL stores float32 coordinates, so each coordinate comes back within half an ulp:
    # |x| * 2^-24 <= 0.6 m * 6e-8 = 3.6e-8 m; we allow 2^-24 * max|x| per file.
    paths = tool.export_stl(tmp_path)
    assert sorted(paths) == ["lower", "upper", "whole"] and all(p.is_file() for p in paths.values())
    loaded = load_sweep(paths["lower"], paths["upper"], tool.pivot, tool.sensor_point, com=None)
    for orig, back in ((tool.lower, loaded.lower), (tool.upper, loaded.upper)):
        tol = 2.0**-24 * np.abs(orig.vertices).max()
        assert len(back.vertices) == len(orig.vertices) and len(back.faces) == len(orig.faces)
        # same triangles in the same order (vertex indices may be renumbered by trimesh's merge)
        assert np.abs(back.vertices[back.faces] - orig.vertices[orig.faces]).max() <= tol
        assert back.to_trimesh(process=True).is_watertight
    assert np.allclose(loaded.com, tool.com, rtol=0, atol=1e-6)  # centroid of float32-rounded solids
    assert np.allclose(loaded.tip, tool.tip, rtol=0, atol=1e-7)
    assert np.array_equal(loaded.inertia, paper_inertia_about_com()) and loaded.mass == PAPER_MASS
    whole = trimesh.load(paths["whole"], force="mesh", process=False)
    assert len(whole.faces) == len(tool.lower.faces) + len(tool.upper.faces)


def test_load_errors_name_the_parameter(tool, tmp_path) -> None:
    paths = tool.export_stl(tmp_path)
    with pytest.raises(InputError, match="lower_stl.*nothing.stl"):
        load_sweep(tmp_path / "nothing.stl", paths["upper"], tool.pivot, tool.sensor_point)
    empty = tmp_path / "empty.stl"
    empty.write_text("solid empty\nendsolid empty\n")
    with pytest.raises(InputError, match="upper_stl.*empty.stl"):
        load_sweep(paths["lower"], empty, tool.pivot, tool.sensor_point)
    with pytest.raises(InputError, match="mass must be > 0, got -1.0"):
        load_sweep(paths["lower"], paths["upper"], tool.pivot, tool.sensor_point, mass=-1.0)
    with pytest.raises(InputError, match="spring_direction"):
        load_sweep(paths["lower"], paths["upper"], tool.pivot, tool.sensor_point, spring_direction=(0, 0, 0))


# ---------------------------------------------------------------------------------------------- as a body
def test_add_sweep_makes_one_body_with_paper_mass_properties(tool) -> None:
    # Reference: the builder stores mass and principal moments (eigenvalues of the tensor about the COM); both
    # halves belong to the one body. Tolerance 1e-12 relative: the eigen-decomposition in float64.
    b = wd.ModelBuilder()
    b.add_material("steel", STEEL)
    body = add_sweep(b, tool, "steel", velocity=(0.0, 0.5, 0.0))
    model, state = b.finalize(DEVICE)
    assert model.host["body_mass"][body] == pytest.approx(PAPER_MASS, rel=1e-15)
    moments = np.sort(model.body_inertia.numpy()[body])
    assert np.allclose(moments, np.linalg.eigvalsh(paper_inertia_about_com()), rtol=1e-12, atol=0)
    names = model.names["mesh"]
    assert model.host["mesh_body"][names["sweep_lower"]] == model.host["mesh_body"][names["sweep_upper"]] == body
    assert np.allclose(state.body_pos.numpy()[body], tool.com, rtol=0, atol=1e-12)
    assert np.allclose(state.body_vel.numpy()[body], [0.0, 0.5, 0.0])
    # hinged by default: rotation about x only, translation slaved to the pivot, which is the tool's pivot point
    assert model.host["body_flags"][body] & ALL_DOFS == dof_mask("YZ")
    assert model.host["body_flags"][body] & FLAG_PIVOT
    assert np.allclose(state.body_pos.numpy()[body] + quat_to_matrix(state.body_quat.numpy()[body])
                       @ model.host["body_pivot"][body], tool.pivot, rtol=0, atol=1e-12)
