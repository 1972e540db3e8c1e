"""The kernels' argument structs (warpdem/kernel_args.py, the settings types.Options, the laws' material tables):
every field documented with its dtype, and every array field set by the host builders from a simulation's model,
state and data (the same arrays, no copies). The host-side types (types.Control, types.Contacts): every field
documented with its unit, dtype and shape."""

from __future__ import annotations

import ast
import dataclasses
import inspect
import re

import numpy as np
import warp as wp
from conftest import DEVICE
from test_worlds import packing_scene

import warpdem as wd
from warpdem import kernel_args as ka
from warpdem import types, world_steps
from warpdem.accumulate import vec3l
from warpdem.laws import CohFrictMaterials, HertzMindlinMaterials, Hist, MaterialTables

DTYPE_WORDS = {
    wp.int32: "int32", wp.float32: "float32", wp.float64: "float64", wp.uint64: "uint64", wp.int64: "int64",
    wp.vec3f: "vec3f", wp.vec3d: "vec3d", wp.quatd: "quatd", vec3l: "vec3l", Hist: "Hist", int: "int32",
    float: "float32",
}
"""how a field's docstring names each array dtype (and each scalar's, in types.Options)."""
STRUCT = type(ka.Bodies)
"""the type of a @wp.struct."""


def _structs() -> list[type]:
    return [c for m in (ka, world_steps, types) for _, c in inspect.getmembers(m)
            if isinstance(c, STRUCT) and c.cls.__module__ == m.__name__] + [CohFrictMaterials, HertzMindlinMaterials]


def _field_docs(struct: STRUCT | type) -> dict[str, str]:
    """Field name -> the docstring that follows its annotation in the class body (the laws' material tables take
    their fields, and their docs, from MaterialTables)."""
    if struct in (CohFrictMaterials, HertzMindlinMaterials):
        struct = MaterialTables
    tree = ast.parse(inspect.getsource(getattr(struct, "cls", struct)).lstrip())
    body = tree.body[0].body
    docs = {}
    for stmt, nxt in zip(body, body[1:] + [None], strict=True):
        if isinstance(stmt, ast.AnnAssign):
            doc = nxt.value.value if isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant) else ""
            docs[stmt.target.id] = doc
    return docs


def test_every_field_is_documented_with_its_dtype() -> None:
    structs = _structs()
    assert {"Bodies", "Spheres", "Meshes", "Springs", "BodyState", "SphereState", "SphereList", "TriangleList",
            "Sums", "Advance", "Worlds", "Options", "CohFrictMaterials",
            "HertzMindlinMaterials"} <= {s.key for s in structs}
    for struct in structs:
        docs = _field_docs(struct)
        assert list(docs) == list(struct.vars), struct.key  # every field, in order, has an annotation here
        for name, var in struct.vars.items():
            doc = docs[name]
            assert doc.strip(), f"{struct.key}.{name} has no docstring"
            if isinstance(var.type, wp.array) or struct is types.Options:
                word = DTYPE_WORDS[var.type.dtype if isinstance(var.type, wp.array) else var.type]
                assert word in doc, f"{struct.key}.{name}: the docstring should name the dtype {word}: {doc!r}"


def test_builders_set_every_array_with_the_simulations_own() -> None:
    model, state = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=2)
    sim = wd.Simulation(model, state, dt=2e-5, contact_threads="pair")
    d, c = sim.data, sim.contacts
    built = {
        "bodies": ka.bodies_of(model, sim.control), "spheres": ka.spheres_of(model), "meshes": ka.meshes_of(model, d),
        "springs": ka.springs_of(model), "state": ka.body_state_of(state), "kin": ka.sphere_state_of(d),
        "ss": ka.sphere_list_of(c.ss), "st": ka.triangle_list_of(c.st), "sums": ka.sums_of(d),
    }
    for name, struct in built.items():
        for field, var in struct._cls.vars.items():
            if isinstance(var.type, wp.array):
                assert getattr(struct, field) is not None, f"{name}.{field}"
    assert built["spheres"].radius is model.sphere_radius
    assert built["bodies"].group_damping is sim.control.group_damping
    assert built["bodies"].pivot_vel is sim.control.pivot_vel
    assert built["state"].pos is state.body_pos
    assert built["ss"].hist is c.ss.hist and built["ss"].owner is c.ss.owner
    assert built["sums"].force_acc is d.force_acc
    # a part's sums: its own slots of the accumulators, the whole float results
    part = ka.sums_of(d, 0, whole=False)
    assert part.force_acc.shape[0] == model.n_bodies and part.body_force is d.body_force


def test_options_hold_the_simulations_settings() -> None:
    """dt reaches the kernels once (float64; the law rounds it to float32 as the host would)."""
    model, state = packing_scene(np.zeros(3)).finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=2e-5, skin=1e-3, unp_max=-1.0, bond_detection_factor=1.1)
    o = sim.options
    assert o.dt == 2e-5 and np.float32(o.skin) == np.float32(1e-3) and o.unp_max == -1.0
    assert np.float32(o.bond_gap) == np.float32(0.1) and o.max_speed == sim.max_speed
    assert tuple(o.lower) == tuple(sim.bounds[0]) and tuple(o.upper) == tuple(sim.bounds[1])


HOST_TYPES = (types.Control, types.Contacts)
"""the host-side dataclasses of types.py whose fields are arrays."""
ARRAY_WORDS = ("int32", "float32", "float64", "vec3f", "vec3d", "quatd", "vec3l", "Hist", "uint64", "int64")


def test_host_types_document_unit_dtype_and_shape() -> None:
    """Every field of types.Control and types.Contacts: a docstring with a unit in brackets, a dtype and a shape
    in parentheses."""
    for cls in HOST_TYPES:
        docs = _field_docs(cls)
        assert list(docs) == [f.name for f in dataclasses.fields(cls)], cls.__name__
        for name, doc in docs.items():
            where = f"{cls.__name__}.{name}: {doc!r}"
            assert re.search(r"\[[^\]]*\]", doc), f"{where} names no unit"
            assert any(w in doc for w in ARRAY_WORDS), f"{where} names no dtype"
            assert re.search(r"\w,\)", doc), f"{where} names no shape"  # (n,) or (a * b,)


def test_control_holds_copies_of_the_models_values() -> None:
    model, state = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=2)
    sim = wd.Simulation(model, state, dt=2e-5)
    c = sim.control
    for field in dataclasses.fields(types.Control):
        arr = getattr(c, field.name)
        assert arr is not getattr(model, {"pivot_vel": "body_pivot_vel"}.get(field.name, field.name))
        assert arr.device == model.device
    np.testing.assert_array_equal(c.group_damping.numpy(), model.group_damping.numpy())


def test_contacts_hold_the_lists_the_kernels_read() -> None:
    model, state = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=2)
    sim = wd.Simulation(model, state, dt=2e-5)
    c = sim.contacts
    assert c.build_pos.shape == (model.n_spheres,) and c.list_stats.shape == (4,)
    assert c.ss.other is c.ss.key_a and c.st.mesh is c.st.key_a and c.st.face is c.st.key_b
    stats = c.list_stats.numpy()
    assert stats[0] >= c.ss.count.numpy().sum() and stats[2] == 0
