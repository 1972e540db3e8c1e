"""The passively vibrated sweep tool of the reference study (paper sections 2.1.1 and 2.1.2), as a two-part mesh.

Frame (all warpdem rigs): x lateral (= the pivot axis), y = travel direction (the tool moves toward +y), z up
(gravity along -z). Units: SI (m, kg, kg m^2); angles in degrees at this API.

The paper's tool: a 300 mm wide sweep with a 20 deg attack angle on a shank; the shank's upper end has a hole
holding the pivot (the tool's rotation centre, rotation allowed about X); plate springs push on the shank's upper
part; the displacement sensor / spring contact point is 100 mm from the rotation centre; working depth 150 mm.
In the simulation the tool's STL is split into a lower half (its soil contact force is the draught) and an upper
half (where the springs act); both halves form ONE rigid body. Mass properties (SolidWorks, "calculated at the
output coordinate system"): mass 7.692 kg, centre of mass R (eq. 2) and the matrix of eq. (1), both in the CAD
frame.

Sign convention of eq. (1) (verified in tests/test_sweep.py): its off-diagonal entries are SolidWorks' PRODUCTS of
inertia P_ij = +int x_i x_j dm about the CAD origin, not tensor components. The inertia TENSOR is
I = diag(I_xx, I_yy, I_zz) - (P off the diagonal); the parallel-axis theorem moves it to the centre of mass c:
P_ij(c) = P_ij(O) - m c_i c_j and I_ii(c) = I_ii(O) - m (|c|^2 - c_i^2). Evidence: m c_y c_z = 1.027 ~ printed
I_yz = 1.0619 (the origin is far from the tool); with this reading the COM products involving x are ~0 (1.4e-4 and
2.3e-3 kg m^2: a sweep is nearly symmetric about its mid-plane x = const) and the COM tensor is positive definite.
Reading the entries as tensor components instead gives a tensor that is positive definite about the CAD origin but
NOT about the COM (I_yy I_zz < I_yz^2 there): physically impossible.

Assumption: the CAD axes have the simulation axes' orientation (CAD x = the pivot axis, as the paper allows
rotation about X). The CAD origin is not located on our parametric geometry, so the paper's COM position relative
to the pivot is unknown: the parametric sweep puts its COM at the volume centroid of its own geometry and uses the
paper's mass and the paper's inertia about the COM (converted as above); the inertia about the pivot then follows
by the parallel-axis theorem with our geometry (:meth:`SweepTool.inertia_about`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from warpdem import mass as massprops
from warpdem.errors import InputError, check_positive, check_range, check_vec3

if TYPE_CHECKING:
    import trimesh

    from warpdem.builder import ModelBuilder

# ----------------------------------------------------------------------------------------------- paper's values
#: mass of the sweep with its shank [kg] (paper section 2.1.1)
PAPER_MASS = 7.692
#: centre of mass in the CAD frame [m] (paper eq. 2)
PAPER_COM_CAD = np.array([-0.0051, 0.4930, 0.2709])
#: eq. (1) as printed [kg m^2], about the CAD origin: moments on the diagonal, PRODUCTS of inertia
#: P_ij = +int x_i x_j dm off the diagonal (SolidWorks' convention, see the module docstring)
PAPER_PRODUCTS_CAD = np.array(
    [
        [2.6007, -0.0192, -0.0083],
        [-0.0192, 0.7211, 1.0619],
        [-0.0083, 1.0619, 1.9056],
    ]
)
#: tillage depth of the soil bin tests [m] (paper section 2.1.2)
PAPER_WORKING_DEPTH = 0.150

_CONVENTIONS = ("products", "tensor")


def printed_to_tensor(printed: np.ndarray, *, convention: str = "products") -> np.ndarray:
    """Inertia tensor [kg m^2] (3, 3) from a printed inertia matrix, about the same point, same axes.

    Args:
        printed: (3, 3) moments on the diagonal; off the diagonal either products of inertia
            P_ij = +int x_i x_j dm (``convention="products"``, SolidWorks) or tensor components
            I_ij = -int x_i x_j dm (``convention="tensor"``).
    """
    printed = np.asarray(printed, dtype=np.float64)
    if printed.shape != (3, 3):
        raise InputError(f"printed_matrix must have shape (3, 3), got {printed.shape}")
    if convention not in _CONVENTIONS:
        raise InputError(f"convention must be one of {list(_CONVENTIONS)}, got {convention!r}")
    if convention == "tensor":
        return printed.copy()
    diag = np.diag(np.diag(printed))
    return diag - (printed - diag)


def inertia_about_com(
    printed_matrix: np.ndarray, mass: float, com: np.ndarray, *, convention: str = "products"
) -> np.ndarray:
    """Inertia tensor about the centre of mass [kg m^2] (3, 3), from a matrix printed about the frame origin.

    The tensor convention is warpdem's: I = int (|r|^2 1 - r r^T) dm, off-diagonal entries are MINUS the products
    of inertia. Parallel axis: I(c) = I(O) - m (|c|^2 1 - c c^T). Axes: those of the printed matrix (CAD axes for
    the paper's values). The result is not checked for positive definiteness (see :func:`warpdem.mass.principal_axes`).

    Args:
        printed_matrix: (3, 3) [kg m^2] about the origin; off-diagonal meaning set by ``convention``
            ("products": P_ij = +int x_i x_j dm, SolidWorks; "tensor": already tensor components).
        mass: [kg]. com: centre of mass [m] (3,) in the same frame as the printed matrix.
    """
    check_positive("mass", mass)
    com = check_vec3("com", com)
    return massprops.parallel_axis(printed_to_tensor(printed_matrix, convention=convention), mass, com)


def inertia_about_point(inertia_com: np.ndarray, mass: float, com: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Inertia tensor [kg m^2] (3, 3) about ``point`` (same axes): I_p = I_c + m (|d|^2 1 - d d^T), d = com - point.

    Args:
        inertia_com: tensor about the centre of mass [kg m^2] (3, 3) (off-diagonal = minus products of inertia).
        mass: [kg]. com, point: [m] (3,), same frame.
    """
    check_positive("mass", mass)
    d = check_vec3("com", com) - check_vec3("point", point)
    return np.asarray(inertia_com, dtype=np.float64) + mass * (massprops.dot3(d, d) * np.eye(3) - np.outer(d, d))


def paper_inertia_about_com() -> np.ndarray:
    """The paper's inertia tensor about its centre of mass [kg m^2] (3, 3), CAD axes (= simulation axes, assumed).

    Eq. (1) read as SolidWorks products of inertia about the CAD origin, moved to R of eq. (2) with m = 7.692 kg.
    """
    return inertia_about_com(PAPER_PRODUCTS_CAD, PAPER_MASS, PAPER_COM_CAD, convention="products")


# ------------------------------------------------------------------------------------------------------ meshes
@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh: vertices [m] (nv, 3) float64, faces (nf, 3) int vertex indices, outward winding.

    It may hold several closed components (each closed on its own).
    """

    vertices: np.ndarray
    faces: np.ndarray

    def to_trimesh(self, process: bool = False) -> trimesh.Trimesh:
        """A trimesh.Trimesh of this mesh (``process`` merges coincident vertices)."""
        import trimesh

        return trimesh.Trimesh(vertices=self.vertices, faces=self.faces, process=process)

    def moved(self, offset: np.ndarray) -> Mesh:
        """This mesh translated by ``offset`` [m] (3,)."""
        return Mesh(self.vertices + np.asarray(offset, dtype=np.float64), self.faces.copy())


def _concat(meshes: list[Mesh]) -> Mesh:
    """One Mesh holding the given meshes as separate components."""
    verts, faces, start = [], [], 0
    for m in meshes:
        verts.append(m.vertices)
        faces.append(m.faces + start)
        start += len(m.vertices)
    return Mesh(np.concatenate(verts), np.concatenate(faces).astype(np.int64))


def _prism(bottom: np.ndarray, top: np.ndarray, triangles: list[tuple[int, int, int]]) -> Mesh:
    """Closed prism between two polygons of k vertices each (bottom[i] joined to top[i] by a planar side face).

    Args:
        bottom, top: [m] (k, 3), counter-clockwise seen from above (+z).
        triangles: a triangulation of the polygon, counter-clockwise index triples into 0..k-1.
    Returns the mesh with outward normals: top faces up, bottom faces down, side faces outward.
    """
    k = len(bottom)
    tri = np.asarray(triangles, dtype=np.int64)
    sides = []
    for i in range(k):
        j = (i + 1) % k
        sides += [(i, j, k + j), (i, k + j, k + i)]
    faces = np.concatenate([tri[:, ::-1], tri + k, np.asarray(sides, dtype=np.int64)])
    return Mesh(np.concatenate([bottom, top]).astype(np.float64), faces)


def _fan(k: int) -> list[tuple[int, int, int]]:
    """Fan triangulation of a convex k-gon."""
    return [(0, i, i + 1) for i in range(1, k - 1)]


# -------------------------------------------------------------------------------------------------- parameters
@dataclass(frozen=True)
class SweepParams:
    """Dimensions of the parametric sweep (lengths [m], angles [deg]).

    Attributes:
        width: span of the blade across travel (x extent) [m]; 0.300 (paper).
        attack_angle: angle between the blade's upper surface and the horizontal [deg]; 20 (paper). The surface
            rises toward the rear, so the soil climbs it as the tool moves toward +y.
        sweep_angle: angle, in plan view, between each wing's leading edge and the travel direction [deg]. Not
            given in the paper; 40 (an 80 deg included angle, within the 70-90 deg of common duck-foot sweeps).
        wing_chord: length of each wing along the travel direction, plan view [m]; 0.080 (assumed; with the
            40 deg sweep this gives a 0.26 m long blade, in proportion to a 0.30 m sweep).
        thickness: plate thickness, normal to the blade surfaces [m]; 0.006 (typical sweep steel plate).
        shank_depth: shank section along y (travel) [m]; 0.040 (assumed, a common flat-bar shank).
        shank_width: shank section along x [m]; 0.020 (assumed).
        shank_length: vertical distance from the pivot (the shank's top end) down to the blade tip (the tool's
            lowest point) [m]; 0.600 puts the pivot 0.45 m above the soil surface at the 0.15 m working depth.
            The shank is vertical (the paper gives no inclination; a vertical shank keeps the pivot above the foot).
        sensor_distance: distance along the shank axis (vertical) from the pivot down to the spring / sensor
            point on the shank's rear face [m]; 0.100 (paper). It is the lever arm of a spring force along y and
            the ratio of the point's y displacement to a small rotation about x.
        working_depth: depth of the tip below the soil surface [m]; 0.150 (paper). It places no geometry; see
            :attr:`SweepTool.soil_surface_z`.
        split_below_pivot: depth of the split plane below the pivot [m], between the spring point and the blade's
            top. None: midway between them, so the lower half holds the blade and the lower shank and the upper
            half holds the springs' contact point.
    """

    width: float = 0.300
    attack_angle: float = 20.0
    sweep_angle: float = 40.0
    wing_chord: float = 0.080
    thickness: float = 0.006
    shank_depth: float = 0.040
    shank_width: float = 0.020
    shank_length: float = 0.600
    sensor_distance: float = 0.100
    working_depth: float = PAPER_WORKING_DEPTH
    split_below_pivot: float | None = None

    def __post_init__(self) -> None:
        for name in ("width", "wing_chord", "thickness", "shank_depth", "shank_width", "shank_length",
                     "sensor_distance", "working_depth"):
            check_positive(name, getattr(self, name))
        for name in ("attack_angle", "sweep_angle"):
            value = getattr(self, name)
            check_range(name, value, 0.0, 90.0, high_open=True)
            if value == 0.0:
                raise InputError(f"{name} must be > 0 deg, got {value!r}")
        if self.shank_width > self.width:
            raise InputError(f"shank_width must be <= width ({self.width}), got {self.shank_width!r}")
        room = self.wing_chord - self.tip_setback()
        if self.shank_depth >= room:
            raise InputError(
                f"shank_depth must be < {room:.6g} m (wing_chord minus the leading-edge setback at the shank's "
                f"sides) so that the shank's foot sits on the blade, got {self.shank_depth!r}"
            )
        if self.blade_height() + self.sensor_distance >= self.shank_length:
            raise InputError(
                f"shank_length must exceed blade height + sensor_distance = "
                f"{self.blade_height() + self.sensor_distance:.6g} m, got {self.shank_length!r}"
            )
        if self.split_below_pivot is not None:
            low, high = self.sensor_distance, self.shank_length - self.blade_height()
            if not low < self.split_below_pivot < high:
                raise InputError(
                    f"split_below_pivot must lie strictly between the spring point ({low:.6g} m) and the blade's "
                    f"top ({high:.6g} m below the pivot), got {self.split_below_pivot!r}"
                )

    def tip_setback(self) -> float:
        """How far (y) the leading edge lies behind the tip at the shank's sides, x = +-shank_width/2 [m]."""
        return 0.5 * self.shank_width / math.tan(math.radians(self.sweep_angle))

    def wing_length(self) -> float:
        """Plan-view distance (y) from the tip back to the wing ends' leading corners [m]."""
        return 0.5 * self.width / math.tan(math.radians(self.sweep_angle))

    def vertical_thickness(self) -> float:
        """Plate thickness measured along z [m]: thickness / cos(attack_angle) (the plate's side faces are vertical)."""
        return self.thickness / math.cos(math.radians(self.attack_angle))

    def blade_height(self) -> float:
        """Height of the blade's top (rear corners of the upper surface) above the tip [m]."""
        run = self.wing_length() + self.wing_chord
        return run * math.tan(math.radians(self.attack_angle)) + self.vertical_thickness()

    def split_depth(self) -> float:
        """Depth of the split plane below the pivot [m] (the default is midway: spring point / blade top)."""
        if self.split_below_pivot is not None:
            return float(self.split_below_pivot)
        return 0.5 * (self.sensor_distance + self.shank_length - self.blade_height())


# ------------------------------------------------------------------------------------------------------ tool
@dataclass(frozen=True, eq=False)
class SweepTool:
    """A sweep tool ready for a scene: two meshes of one rigid body, its key points and mass properties.

    Attributes:
        lower: blade + lower shank (soil contact; its contact force is the draught), closed solids [m].
        upper: upper shank (springs and pivot), closed solids [m].
        pivot: rotation centre (the hole at the shank's top end) [m] (3,).
        sensor_point: spring contact / displacement sensor point on the shank's rear face [m] (3,).
        spring_direction: unit vector (3,) along which the springs push the shank (+y: from behind).
        tip: the blade's lowest, most forward point [m] (3,).
        mass: [kg]. com: centre of mass [m] (3,). inertia: tensor about com, world axes [kg m^2] (3, 3).
        split_height: z of the plane between the halves [m] (None if unknown, for a loaded tool).
        working_depth: depth of the tip below the soil surface [m].
        params: the SweepParams it was built from (None for a loaded STL).
    """

    lower: Mesh
    upper: Mesh
    pivot: np.ndarray
    sensor_point: np.ndarray
    spring_direction: np.ndarray
    tip: np.ndarray
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    split_height: float | None = None
    working_depth: float = PAPER_WORKING_DEPTH
    params: SweepParams | None = field(default=None)

    @property
    def whole(self) -> Mesh:
        """Both halves as one mesh (two or more closed components)."""
        return _concat([self.lower, self.upper])

    @property
    def soil_surface_z(self) -> float:
        """z of the soil surface for the tip at ``working_depth`` [m]."""
        return float(self.tip[2] + self.working_depth)

    def inertia_about(self, point: np.ndarray) -> np.ndarray:
        """Inertia tensor about ``point`` [kg m^2] (3, 3), world axes (e.g. ``tool.pivot``)."""
        return inertia_about_point(self.inertia, self.mass, self.com, point)

    def moved(self, offset: np.ndarray) -> SweepTool:
        """This tool translated by ``offset`` [m] (3,) (the inertia tensor is unchanged)."""
        off = check_vec3("offset", offset)
        return dataclasses.replace(
            self,
            lower=self.lower.moved(off),
            upper=self.upper.moved(off),
            pivot=self.pivot + off,
            sensor_point=self.sensor_point + off,
            tip=self.tip + off,
            com=self.com + off,
            split_height=None if self.split_height is None else self.split_height + float(off[2]),
        )

    def pitched(self, angle: float) -> SweepTool:
        """This tool turned backwards by ``angle`` [deg] about its pivot's axis (x): its lower points move against
        travel (-y) and its tip rises, as the springs let the passive tool bend back (negative: forwards)."""
        rot = pitch_matrix(angle)
        pivot = self.pivot

        def turn(p: np.ndarray) -> np.ndarray:
            return massprops.rows_times(np.asarray(p, dtype=np.float64) - pivot, rot.T) + pivot

        return dataclasses.replace(
            self,
            lower=Mesh(turn(self.lower.vertices), self.lower.faces.copy()),
            upper=Mesh(turn(self.upper.vertices), self.upper.faces.copy()),
            sensor_point=turn(self.sensor_point),
            spring_direction=massprops.rows_times(self.spring_direction, rot.T),
            tip=turn(self.tip),
            com=turn(self.com),
            inertia=massprops.rows_times(massprops.rows_times(rot, self.inertia), rot.T),
            split_height=None,
        )

    def export_stl(self, directory: str | Path) -> dict[str, Path]:
        """Write lower.stl, upper.stl and whole.stl (binary STL, float32 coordinates [m]) into ``directory``.

        Returns the paths by name ("lower", "upper", "whole").
        """
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        paths = {}
        for name, mesh in (("lower", self.lower), ("upper", self.upper), ("whole", self.whole)):
            paths[name] = out / f"{name}.stl"
            mesh.to_trimesh().export(paths[name])
        return paths


def pitch_matrix(angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) of a backward pitch by ``angle`` [deg]: about +x by -angle (y forward, z up, so a
    point below the pivot moves to -y)."""
    t = math.radians(-float(angle))
    c, s = math.cos(t), math.sin(t)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _volume_centroid(meshes: list[Mesh]) -> tuple[float, np.ndarray]:
    """Total volume [m^3] and volume centroid [m] (3,) of closed, non-overlapping meshes."""
    vols, cents = [], []
    for m in meshes:
        tm = m.to_trimesh()
        vols.append(float(tm.volume))
        cents.append(np.asarray(tm.center_mass, dtype=np.float64))
    vols_arr = np.asarray(vols)
    return float(vols_arr.sum()), (vols_arr[:, None] * np.asarray(cents)).sum(axis=0) / vols_arr.sum()


def _blade(p: SweepParams, tip: np.ndarray) -> Mesh:
    """The V-shaped (chevron) blade: a plan-view chevron extruded vertically, its bottom on the inclined plane
    z = tip_z + tan(attack) (tip_y - y) and its top ``vertical_thickness`` above (so the top and bottom planes
    are ``thickness`` apart, normal (0, sin a, cos a)). Side faces are vertical; the tip is the bottom front
    corner."""
    half, wing, chord = 0.5 * p.width, p.wing_length(), p.wing_chord
    # plan polygon (x, y) relative to the tip, counter-clockwise seen from above:
    # tip, left wing leading corner, left wing trailing corner, rear notch, right trailing, right leading
    plan = np.array([[0.0, 0.0], [-half, -wing], [-half, -wing - chord], [0.0, -chord], [half, -wing - chord],
                     [half, -wing]])
    slope = math.tan(math.radians(p.attack_angle))
    z_bottom = -slope * plan[:, 1]
    bottom = np.column_stack([plan, z_bottom]) + tip
    top = bottom + np.array([0.0, 0.0, p.vertical_thickness()])
    # two convex wings: (tip, left lead, left trail, notch) and (tip, notch, right trail, right lead)
    triangles = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5)]
    return _prism(bottom, top, triangles)


def _shank(p: SweepParams, pivot: np.ndarray, tip: np.ndarray, split_z: float) -> tuple[Mesh, Mesh]:
    """The vertical shank, a rectangular bar centred on the pivot's (x, y), split at ``split_z``.

    Lower part: from the blade's upper surface (its bottom face lies on that inclined plane, so it rests on the
    blade without overlap) up to the split plane. Upper part: from the split plane up to the pivot's height.
    """
    hx, hy = 0.5 * p.shank_width, 0.5 * p.shank_depth
    corners = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]]) + pivot[:2]  # counter-clockwise from above
    slope = math.tan(math.radians(p.attack_angle))
    z_foot = tip[2] + slope * (tip[1] - corners[:, 1]) + p.vertical_thickness()

    def column(z_lo: np.ndarray, z_hi: np.ndarray) -> Mesh:
        return _prism(np.column_stack([corners, z_lo]), np.column_stack([corners, z_hi]), _fan(4))

    ones = np.ones(4)
    return column(z_foot, split_z * ones), column(split_z * ones, pivot[2] * ones)


def build_sweep(params: SweepParams | None = None, *, pivot: object = (0.0, 0.0, 0.0)) -> SweepTool:
    """Build the parametric sweep with its pivot (the shank's top end, on the shank axis) at ``pivot`` [m].

    The shank goes down (-z) from the pivot; the blade sits at its foot and points forward (+y). The shank's foot
    is centred (along y) on the strip of blade under it, so it rests wholly on the blade's upper surface.
    Mass properties: mass = PAPER_MASS, com = volume centroid of this geometry, inertia = the paper's tensor about
    its COM (CAD axes taken as the simulation axes).
    """
    p = params or SweepParams()
    pivot = check_vec3("pivot", pivot)
    # shank axis y = the middle of the blade strip under the shank, [tip - wing_chord, tip - tip setback]
    tip_ahead = 0.5 * (p.wing_chord + p.tip_setback())
    tip = pivot + np.array([0.0, tip_ahead, -p.shank_length])
    split_z = float(pivot[2] - p.split_depth())
    blade = _blade(p, tip)
    shank_lower, shank_upper = _shank(p, pivot, tip, split_z)
    lower, upper = _concat([blade, shank_lower]), shank_upper
    _, com = _volume_centroid([lower, upper])
    rear_y = pivot[1] - 0.5 * p.shank_depth
    return SweepTool(
        lower=lower,
        upper=upper,
        pivot=pivot.copy(),
        sensor_point=np.array([pivot[0], rear_y, pivot[2] - p.sensor_distance]),
        spring_direction=np.array([0.0, 1.0, 0.0]),
        tip=tip,
        mass=PAPER_MASS,
        com=com,
        inertia=paper_inertia_about_com(),
        split_height=split_z,
        working_depth=p.working_depth,
        params=p,
    )


def _load_stl(label: str, path: str | Path, scale: float) -> Mesh:
    """Read a mesh file (vertices merged), scaled to m; errors name the parameter and the path."""
    import trimesh

    if not Path(path).is_file():
        raise InputError(f"{label} must be an existing mesh file, got {str(path)!r}")
    try:
        tm = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # noqa: BLE001 - trimesh raises many types for unreadable files
        raise InputError(f"{label} {str(path)!r} could not be read: {exc}") from None
    if len(getattr(tm, "faces", ())) == 0:
        raise InputError(f"{label} {str(path)!r} has no faces")
    return Mesh(np.asarray(tm.vertices, dtype=np.float64) * scale, np.asarray(tm.faces, dtype=np.int64))


def load_sweep(
    lower_stl: str | Path,
    upper_stl: str | Path,
    pivot: object,
    sensor_point: object,
    *,
    spring_direction: object = (0.0, 1.0, 0.0),
    tip: object | None = None,
    mass: float = PAPER_MASS,
    com: object | None = None,
    inertia: object | None = None,
    scale: float = 1.0,
    working_depth: float = PAPER_WORKING_DEPTH,
) -> SweepTool:
    """A SweepTool from the user's own lower/upper STL files, placed in the simulation frame already.

    Args:
        lower_stl, upper_stl: mesh files (any format trimesh reads); coordinates times ``scale`` give metres.
        pivot, sensor_point: [m] (3,), simulation frame.
        spring_direction: (3,) direction of the spring force on the shank, normalised here (default +y).
        tip: the blade's tip [m] (3,); default: the lowest vertex of the lower half (the most forward among ties).
        mass: [kg] (default PAPER_MASS). com: [m] (3,); default: the volume centroid of both halves (each must
            then be closed). inertia: about com, world axes [kg m^2] (3, 3); default paper_inertia_about_com().
        working_depth: depth of the tip below the soil surface [m].
    """
    check_positive("scale", scale)
    check_positive("mass", mass)
    check_positive("working_depth", working_depth)
    lower, upper = _load_stl("lower_stl", lower_stl, scale), _load_stl("upper_stl", upper_stl, scale)
    direction = check_vec3("spring_direction", spring_direction)
    norm = float(massprops.norm(direction))
    if norm == 0.0:
        raise InputError(f"spring_direction must be non-zero, got {direction.tolist()}")
    if com is None:
        for label, m in (("lower_stl", lower), ("upper_stl", upper)):
            if not m.to_trimesh(process=True).is_watertight:
                raise InputError(f"{label} is not closed (watertight): give com explicitly to use it")
        com_arr = _volume_centroid([lower, upper])[1]
    else:
        com_arr = check_vec3("com", com)
    inertia_arr = paper_inertia_about_com() if inertia is None else np.asarray(inertia, dtype=np.float64)
    massprops.principal_axes(inertia_arr)  # raises InputError naming "inertia" if not a physical tensor
    if tip is None:
        v = lower.vertices
        low = v[v[:, 2] <= v[:, 2].min() + 1e-12]  # ties within 1e-12 m (float noise)
        tip_arr = low[np.argmax(low[:, 1])]
    else:
        tip_arr = check_vec3("tip", tip)
    return SweepTool(
        lower=lower,
        upper=upper,
        pivot=check_vec3("pivot", pivot),
        sensor_point=check_vec3("sensor_point", sensor_point),
        spring_direction=direction / norm,
        tip=np.asarray(tip_arr, dtype=np.float64),
        mass=float(mass),
        com=com_arr,
        inertia=inertia_arr,
        working_depth=float(working_depth),
    )


# ------------------------------------------------------------------------------------------------- builder glue
#: the paper's degrees of freedom: translation along X and rotations about Y and Z blocked (rotation about X free)
MOUNTS = ("hinged", "rigid")


def add_sweep(
    builder: ModelBuilder,
    tool: SweepTool,
    material: str | int,
    *,
    name: str = "sweep",
    mount: str = "hinged",
    velocity: object = (0.0, 0.0, 0.0),
    group: str = "tool",
    **kw: object,
) -> int:
    """Add the tool to a warpdem ModelBuilder as one rigid body carrying two meshes; return its index.

    The lower half becomes the mesh ``f"{name}_lower"`` (its contact force is the draught), the upper half is
    attached to the same body as mesh ``f"{name}_upper"`` (the springs act on it).

    Args:
        builder: a warpdem.ModelBuilder. material: its material name or index (both halves).
        mount: "hinged": a free rigid body (the tool's mass [kg], com [m], inertia about com [kg m^2]) turning
            about ``tool.pivot`` carried at ``velocity``, rotation only about x (the paper's passive tool);
            "rigid": every DoF blocked, moving at ``velocity`` (the paper's rigid tool).
        velocity: carriage velocity [m/s] (3,). group: body group (observers and damping).
        kw: passed on to ``builder.add_mesh`` for the lower half (e.g. angular_velocity).
    """
    if mount not in MOUNTS:
        raise ValueError(f"mount must be one of {MOUNTS}, got {mount!r}")
    if mount == "hinged":
        body = builder.add_mesh(
            f"{name}_lower", tool.lower.vertices, tool.lower.faces, material, kind="dynamic", mass=tool.mass,
            com=tool.com, inertia=tool.inertia, blocked="YZ", pivot=tool.pivot, velocity=velocity, group=group, **kw,
        )
    else:
        body = builder.add_mesh(f"{name}_lower", tool.lower.vertices, tool.lower.faces, material, kind="kinematic",
                                velocity=velocity, group=group, **kw)
    builder.add_mesh(f"{name}_upper", tool.upper.vertices, tool.upper.faces, material, body=body)
    return body
