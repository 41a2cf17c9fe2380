"""A trial's world in Drake (pydrake, the optional extra ``[drake]``): the world description
(sim.world_description) built as a MultibodyPlant, solved by SAP at sim.drake_trial.DRAKE_TIME_STEP, with
each contact pair's model chosen by what it is (docs/model.md 11.19).

* The object is a free body: the description's convex prism or curved solid, its mass from the
  density over its hull. Against the table it makes hydroelastic contact (a rigid hydroelastic
  body on a compliant table), which spreads the force over the patch where the two lie on each
  other; a point contact there carries a resting object on one point that jumps from corner to
  corner.
* A rounded finger's dome makes point contact with the object: it carries no hydroelastic
  representation, and Drake falls back to point contact for its pair. A 1 mm dome pressed by a
  few newtons into a thin prism needs the contact's stiffness from Hertz (POINT_STIFFNESS), not
  from a pressure field across the prism's half-thickness, which it sinks through. Drake computes
  the point contact with FCL's MPR (Minkowski portal refinement), which finds the penetration
  along the line between the two shapes' centres, not the least one: right for the dome on the
  object's face, wrong (normals tens of degrees off, depths several times too deep) for a face
  lying on the object's face or a dome over its rim.
* The thumb touches the object with a pad (thumb_pad): a compliant hydroelastic box behind its
  face, flush with it. A point contact there holds the object's end at one point, about which the
  pinch lets it turn out of the plane (the pick turned 4 deg further than in MuJoCo before the
  drive began, and the jaws closed past the plan's opening); the pad's patch carries the couple
  the face's several contacts carry in MuJoCo. Compliant faces over the thumb's whole mesh (a
  pressure field fanned from its centroid) threw the pick out of the pinch instead, the force
  jumping from 1.3 N to 16 N within a millisecond as the object's edge crossed between the
  field's tetrahedra; a box's field rises with the depth behind its face.
* A flat finger (no dome) touches the object with a pad instead (flat_pad): a compliant
  hydroelastic box behind its face, through its tip edge and leaning back FACE_DRAFT, so that it
  presses along its edge, a patch on the object's face, as the plan's A. Its contact with the
  object is computed from the two shapes' volumes, with no portal; the finger's own mesh does not
  touch the object, and the pad touches nothing else.
* A piece already down (a layout's, world.placed) is a free body with two contact geometries,
  each for the pairs whose model suits them. Its hull, rigid hydroelastic as the object, lies on
  the compliant table in a patch (Drake has no hydroelastic contact of a compliant body with a
  compliant half space: the table's pair with a compliant piece would fall back to point
  contact, on the piece's corners) and meets the hand as the object does. Its field (placed_field),
  compliant hydroelastic, its pressure rising with the depth below its nearest face at
  PAD_GRADIENT (the table's and the pads'), meets the object, the walls and the other pieces' fields.
  A rigid piece would meet the rigid object in a rigid-rigid pair, which Drake has no
  hydroelastic model of: it falls back to point contact by MPR, whose normals for a face or an
  edge against a face come out off (above). Compliant, it meets the object in a patch along the
  faces' normals, the rigid walls in a patch, the other pieces in compliant-compliant patches.
  Drake's own compliant convex field (fanned from the centroid) rises 2 x / t below a face across
  the thickness t but x / r below a side face r from the centroid, ten times softer at a 3 mm
  piece's edges; the mesh here rises alike below every face.
* The fixed solids (the frame's walls, obstacles) are rigid hydroelastic: the object and the
  digits meet them in point contact as before (a rigid-rigid pair, and no hydroelastic
  representation), a piece's field and the housing in a patch.
* The palm rides on six joints from the world (three slides along the world's axes, three
  hinges about axes fixed in the palm's first orientation), each driven by a stiff PD controller
  that SAP applies implicitly (an arm that goes where it is told, the weld of MuJoCo's model),
  toward the drive's poses and velocities (a TrajectorySource), so that the digits carry the
  velocity the contacts' friction sees.
* The jaws slide on the palm, coupled (a coupler constraint, the thumb's slide minus the
  finger's), and one PD servo with an effort limit on the finger's slide drives the opening: the
  description's servo (its stiffness and damping on the opening, its force limit the grip force).
* Each digit hangs on its jaw by a hinge with the description's torsion spring and damping.

Friction: Drake combines a pair's two coefficients as 2 mu1 mu2 / (mu1 + mu2) (for point and
hydroelastic contact alike), where MuJoCo takes the larger. The object's geometry gets
OBJECT_FRICTION and every other geometry the coefficient that makes the combination its pair's
coefficient with the object (geometry_friction): mu OBJECT_FRICTION / (2 OBJECT_FRICTION - mu). SAP uses
the dynamic coefficient; the static one is set equal. A digit on the table (a failure whatever its
friction) then has 2 a b / (a + b) of the two geometries' values, not MuJoCo's larger coefficient;
so has a piece down on a wall or on another piece. A piece's hull carries the object's
coefficient, so that the piece lies on the table with the object's pair coefficient there, as in
MuJoCo's model (the larger of the solids' and the table's, both mu_G)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..errors import ToolError
from .spec import FACE_DRAFT
from .world_description import Box, FreeBody, Geom, Mesh, Sphere, WorldDescription

#: The coefficient the object's own geometry carries (any value above half the largest pair's
#: coefficient serves: every other geometry's is solved from it, geometry_friction).
OBJECT_FRICTION = 1.0
#: Point contact (the finger's dome on the object; a digit on the table): the pair's stiffness
#: (N/m), the Hertz secant stiffness of a 1 mm PLA dome on celluloid at 5 N (docs/model.md 11.2:
#: 5 N over its 0.02 mm indentation). Drake puts two geometries' stiffnesses in series, so each
#: geometry carries twice it.
POINT_STIFFNESS = 2.5e5
#: SAP's dissipation time scale (s, its "relaxation_time", set on each geometry; Drake combines a pair's)
#: of the digits' point contacts: a gram-heavy object on POINT_STIFFNESS is critically damped at
#: 2 sqrt(m / k), 0.1 ms for the 0.8 g pick (stiff plastics hardly bounce).
RELAXATION_TIME = 1e-4
#: The table's and the object's own (s): the object lying flat on the table (1e8 N/m of the pick's
#: face on TABLE_MODULUS / TABLE_SLAB) is critically damped at some 4 us; 1e-5 s each. At 1e-4 s
#: each, a pick dropped flat from a millimetre is thrown 0.2-0.3 mm along the table as it lands.
TABLE_RELAXATION_TIME = 1e-5
OBJECT_RELAXATION_TIME = 1e-5
#: The table's compliant layer (hydroelastic modulus, Pa, and the depth to its rigid core, m): a
#: laminate top's modulus, 3e11 Pa/m between them, the stiffest SAP kept a flat object still on at
#: a 0.1 ms step (at 1e12 Pa/m a pick dropped flat from a millimetre is thrown 2 mm along the table,
#: at 1.4e13 Pa/m off it); at the finer step a table three times stiffer lands the same trials as
#: this one (record 0125). Under the pinch the object's lower edge sinks 0.08 mm into it.
TABLE_MODULUS = 3.0e9
TABLE_SLAB = 0.01
#: The housing's hydroelastic modulus (Pa), a stiff plastic's: it touches only in a failure.
HOUSING_MODULUS = 3.0e9
#: A flat finger's pad (flat_pad): how fast its pressure rises with depth (Pa/m, its hydroelastic
#: modulus over its half depth), the table's: the stiffest SAP keeps a flat object still on.
PAD_GRADIENT = TABLE_MODULUS / TABLE_SLAB
#: Whether the thumb touches the object with its pad (thumb_pad); False gives its mesh a point
#: contact instead, as the builder did before the pad, for the comparison of the two in
#: tools/sim_campaigns.py --contacts --thumb point (docs/model.md 11.19).
THUMB_PAD = True
#: How the object's and the pieces' hulls reach Drake, whose contact patches on a rigid body are cut
#: from its triangles (docs/model.md 11.19): "large-fanned" (record 0116), Drake's own triangles
#: but a face of more than four corners fanned from its centroid (large_faces_fanned); "convex",
#: Drake's Convex of the vertices, every face fanned from one of its corners; "fanned", record
#: 0115's, refused (hull_triangles). tools/bench_sim.py and tools/sim_campaigns.py set it (--drake-hull).
HULLS = "large-fanned"
#: SAP's near-rigid threshold (its default).
NEAR_RIGID = 1.0
#: Hydroelastic geometries' tessellation hint (m); Drake ignores it for convex shapes, half spaces
#: and boxes (a flat finger's pad), which are all there are here.
RESOLUTION = 0.001
#: The palm's PD joints: natural frequency (rad/s) and damping ratio, those of MuJoCo's weld
#: (sim.spec.PALM_SOLREF: a 0.2 ms time constant, critically damped), on the whole hand's mass
#: and (turns) on HAND_TURN_INERTIA.
PALM_FREQUENCY = 5000.0
PALM_DAMPING_RATIO = 1.0
#: The hand's rotational inertia about the palm (kg m^2) that the palm's turning joints' gains are
#: sized for: the housing, the jaws and the digits reach some 0.1 m from the palm's origin.
HAND_TURN_INERTIA = 0.6 * 0.1 ** 2


def geometry_friction(mu: float) -> float:
    """The coefficient a geometry carries so that Drake's combination with the object's
    OBJECT_FRICTION, 2 a b / (a + b), gives the pair's mu."""
    return mu * OBJECT_FRICTION / (2.0 * OBJECT_FRICTION - mu)


def combined_friction(a: float, b: float) -> float:
    """Drake's friction of a pair whose geometries carry a and b."""
    return 2.0 * a * b / (a + b) if a + b > 0 else 0.0


#: Drake's warning, at a plant's first step, that a rigid half space would not touch a deformable
#: body: the worlds built here hold no deformable body, so it says nothing of them.
_NO_DEFORMABLES = "Rigid (non-deformable) half spaces are not currently supported for deformable contact"


def _not_about_deformables(record: logging.LogRecord) -> bool:
    """False for Drake's warning about deformable contact (_NO_DEFORMABLES), True for any other record."""
    return not record.getMessage().startswith(_NO_DEFORMABLES)


def require_drake():
    """pydrake, or ToolError (exit 1, one line) naming the extra that installs it. Drake's logger
    then drops its warning about deformable contact (_NO_DEFORMABLES), and nothing else."""
    try:
        import pydrake  # noqa: F401
    except ImportError:
        raise ToolError("--engine drake needs Drake: pip install 'ungrasp-ompl[drake]' (the drake wheel)") from None
    import pydrake.all as drake

    logger = logging.getLogger("drake")
    if _not_about_deformables not in logger.filters:
        logger.addFilter(_not_about_deformables)
    return drake


def palm_angles(base: NDArray, rot: NDArray) -> NDArray[np.float64]:
    """The palm's three hinge angles (rad) that turn it from base (3, 3: the palm's first
    orientation) to rot: base^T rot = Ry(a) Rx(b) Rz(c), (a, b, c); singular only at b = 90 deg,
    a turn about the palm's x the plans never make."""
    m = base.T @ rot
    b = math.asin(max(-1.0, min(1.0, -m[1, 2])))
    return np.array([math.atan2(m[0, 2], m[2, 2]), b, math.atan2(m[1, 0], m[1, 1])])


def palm_rotation(base: NDArray, angles: NDArray) -> NDArray[np.float64]:
    """The palm's orientation (3, 3) at hinge angles (a, b, c) from base (palm_angles' inverse)."""
    a, b, c = angles
    ry = np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(b), -math.sin(b)], [0.0, math.sin(b), math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0.0], [math.sin(c), math.cos(c), 0.0], [0.0, 0.0, 1.0]])
    return base @ ry @ rx @ rz


@dataclass
class DrakeWorld:
    """A built world: the diagram, its plant and context, the bodies and geometries a trial reads."""

    world: WorldDescription
    diagram: object
    plant: object
    scene_graph: object
    simulator: object
    palm_base: NDArray[np.float64]  #: the palm's first orientation (3, 3), the hinges' reference
    palm_source: object  #: the palm's desired state (TrajectorySource)
    jaw_source: object  #: the servo's desired state (TrajectorySource)
    #: object, palm, thumb, finger, thumb_jaw, finger_jaw, and the pieces down by name (placed0, ...)
    bodies: dict[str, object] = field(default_factory=dict)
    palm_joints: list = field(default_factory=list)
    jaw_joints: dict[str, object] = field(default_factory=dict)  #: thumb, finger
    #: GeometryId -> object, table, thumb, finger, finger_tip, palm, solid (a wall, an obstacle or a piece down)
    geoms: dict[object, str] = field(default_factory=dict)
    #: GeometryId of a flat finger's pad -> how fast its pressure rises with depth (Pa/m)
    pads: dict[object, float] = field(default_factory=dict)

    @property
    def context(self):
        return self.simulator.get_context()

    @property
    def plant_context(self):
        return self.plant.GetMyContextFromRoot(self.simulator.get_context())


def _properties(drake, geom: Geom, friction: float, hydro: str | None, modulus: float = 0.0,
                relaxation: float | None = None):
    props = drake.ProximityProperties()
    drake.AddContactMaterial(None, 2 * POINT_STIFFNESS, drake.CoulombFriction(friction, friction), props)
    props.AddProperty("material", "relaxation_time", RELAXATION_TIME if relaxation is None else relaxation)
    if hydro == "rigid":
        drake.AddRigidHydroelasticProperties(RESOLUTION, props)
    elif hydro == "compliant":
        drake.AddCompliantHydroelasticProperties(RESOLUTION, modulus, props)
    return props


def _shape(drake, geom: Geom, patches: bool = False):
    """Drake's shape of a description geometry and its pose in the body's frame. patches: the
    geometry is rigid hydroelastic on a free body (the object, a piece's hull), whose contact
    patches are cut from its triangles: a mesh then reaches Drake as HULLS says, the same solid as
    Drake's Convex of its vertices."""
    s = geom.shape
    triangulated = None
    if isinstance(s, Mesh) and patches and HULLS != "convex":
        triangulated = hull_triangles(s.vertices) if HULLS == "fanned" else large_faces_fanned(drake, s.vertices)
    if triangulated is not None:
        points, triangles = triangulated
        obj = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in points.tolist())
        obj += "".join(f"f {a} {b} {c}\n" for a, b, c in (triangles + 1).tolist())
        return (drake.Mesh(drake.InMemoryMesh(mesh_file=drake.MemoryFile(obj, ".obj", geom.name + ".obj"))),
                drake.RigidTransform(s.centre))
    if isinstance(s, Mesh):
        return drake.Convex(np.ascontiguousarray(s.vertices.T), geom.name), drake.RigidTransform(s.centre)
    if isinstance(s, Sphere):
        return drake.Sphere(s.radius), drake.RigidTransform(s.centre)
    if isinstance(s, Box):
        return drake.Box(*(2 * s.half)), drake.RigidTransform(s.centre)
    raise TypeError(f"no Drake shape for {s!r}")


def large_faces_fanned(drake, vertices: NDArray) -> tuple[NDArray[np.float64], NDArray[np.int64]] | None:
    """Drake's convex hull of vertices (N, 3; m) as a closed triangle mesh divided as Drake divides
    it, each face fanned from its first corner, except that a face of more than four corners is
    fanned from its centroid (record 0116): its points (M, 3: the hull's vertices, then those
    centroids) and triangles (K, 3, counter-clockwise seen from outside). None where no face has
    more than four corners: Drake's Convex is then the same division.

    A face fanned from a corner that lies in a contact patch crosses the patch with every one of
    its triangles, each a polygon and a SAP constraint at every step (the pick's end on the
    thumb's pad: some 140 slivers); fanned from its centroid, it crosses a patch at its rim with
    the few triangles whose outer sides lie there. Faces of three or four corners keep Drake's
    division, on which an object dropped flat rests as it does under Drake's Convex: record 0115
    divided them otherwise, and a dropped prism slid."""
    hull = drake.Convex(np.ascontiguousarray(np.asarray(vertices, dtype=float).T), "hull").GetConvexHull()
    points = [np.array([hull.vertex(k) for k in range(hull.num_vertices())])]
    data, triangles, k, extra = hull.face_data(), [], 0, hull.num_vertices()
    large = False
    while k < len(data):
        n = data[k]
        ring = np.asarray(data[k + 1:k + 1 + n], dtype=np.int64)
        k += 1 + n
        if n <= 4:
            triangles += [(ring[0], ring[j], ring[j + 1]) for j in range(1, n - 1)]
            continue
        large = True
        points.append(points[0][ring].mean(axis=0)[None])
        triangles += [(extra, ring[j], ring[(j + 1) % n]) for j in range(n)]
        extra += 1
    return (np.vstack(points), np.array(triangles, dtype=np.int64)) if large else None


def hull_triangles(vertices: NDArray) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Record 0115's hull (refused, HULLS "fanned"): the convex hull of vertices (N, 3) as a closed
    triangle mesh, each triangle's corners counter-clockwise seen from outside: its points (M, 3:
    the hull's vertices, then the centroid of each face with more than four corners) and triangles
    (K, 3, indices into points). A face of three or four corners keeps qhull's one or two
    triangles, not Drake's division; a larger face is fanned from its centroid."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import ConvexHull

    hull = ConvexHull(np.asarray(vertices, dtype=float))
    planes = hull.equations / np.linalg.norm(hull.equations[:, :3], axis=1)[:, None]
    here = np.repeat(np.arange(len(planes)), 3)
    there = hull.neighbors.ravel()
    same = np.all(np.abs(planes[here] - planes[there]) <= 1e-9, axis=1)  # neighbours in one plane: one face
    _, face = connected_components(coo_matrix((np.ones(int(same.sum())), (here[same], there[same])),
                                              shape=(len(planes),) * 2), directed=False)
    small = np.bincount(face)[face] <= 2  # a face of one or two simplices: three or four corners
    points = [hull.points]
    triangles = [_outward(hull.points, hull.simplices[small], planes[small])]
    extra = len(hull.points)
    for f in np.unique(face[~small]):  # five corners or more: fanned from the centroid
        mine = face == f
        corners = np.unique(hull.simplices[mine])
        normal = planes[mine][0, :3]
        xyz = hull.points[corners]
        centre = xyz.mean(axis=0)
        u = (xyz[0] - centre) / np.linalg.norm(xyz[0] - centre)
        ring = corners[np.argsort(np.arctan2((xyz - centre) @ np.cross(normal, u), (xyz - centre) @ u))]
        points.append(centre[None])
        triangles.append(np.column_stack([np.full(len(ring), extra), ring, np.roll(ring, -1)]))
        extra += 1
    return np.vstack(points), np.vstack(triangles).astype(np.int64)


def _outward(points: NDArray, triangles: NDArray, planes: NDArray) -> NDArray[np.int64]:
    """The triangles (K, 3) with each one's corners turned counter-clockwise seen from outside its
    plane (planes (K, 4), unit outward normals first)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    flip = np.einsum("ij,ij->i", np.cross(b - a, c - a), planes[:, :3]) < 0
    out = triangles.copy()
    out[flip, 1], out[flip, 2] = triangles[flip, 2], triangles[flip, 1]
    return out


def _inertia(drake, geoms: tuple[Geom, ...]):
    """The spatial inertia (about the body's origin) of a body's geometries, each of its density
    (or its mass)."""
    total = None
    for geom in geoms:
        shape, pose = _shape(drake, geom)
        if geom.density is not None:
            m = drake.CalcSpatialInertia(shape, geom.density)
        else:
            unit = drake.CalcSpatialInertia(shape, 1.0)
            m = drake.SpatialInertia(geom.mass, unit.get_com(), unit.get_unit_inertia())
        m = m.Shift(-pose.translation())
        if total is None:
            total = m
        else:
            total += m
    return total


def build(world: WorldDescription, palm_trajectory, jaw_trajectory, palm_base: NDArray,
          time_step: float | None = None) -> DrakeWorld:
    """The world in Drake: palm_trajectory (a PiecewisePolynomial of the palm's six joint
    coordinates, three positions then palm_angles) and jaw_trajectory (the finger's slide, m) are
    what the PD controllers track; palm_base the palm's first orientation."""
    drake = require_drake()
    if world.thumb.joint != "slide":
        raise ToolError("the Drake world builds the parallel gripper only (a pincer's hinged jaws are MuJoCo's)")
    dt = world.spec.timestep if time_step is None else time_step
    builder = drake.DiagramBuilder()
    plant, scene_graph = drake.AddMultibodyPlant(drake.MultibodyPlantConfig(
        time_step=dt, discrete_contact_approximation="sap", contact_model="hydroelastic_with_fallback",
        sap_near_rigid_threshold=NEAR_RIGID), builder)
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -9.81])
    geoms: dict = {}
    _add_table(drake, plant, world, geoms)
    hand, palm, joints = _add_palm(drake, plant, world, palm_base, geoms)
    gripper, bodies, jaw_joints, pads = _add_jaws(drake, plant, world, palm, geoms)
    bodies["object"] = _add_object(drake, plant, world, geoms)
    hulls, fields = [], []
    for body in world.placed:
        bodies[body.name], hull, compliant = _add_placed(drake, plant, body, geoms)
        hulls.append(hull)
        fields.append(compliant)
    _add_actuators(drake, plant, world, joints, jaw_joints)
    # the hand does not touch itself (MuJoCo's model excludes the same pairs)
    hand_set = plant.CollectRegisteredGeometries([palm, bodies["thumb"], bodies["finger"], bodies["thumb_jaw"],
                                                  bodies["finger_jaw"]])
    plant.Finalize()
    filters = drake.CollisionFilterDeclaration().ExcludeWithin(hand_set)
    obj = next(g for g, kind in geoms.items() if kind == "object")
    for pad in pads:  # a flat finger touches the object with its pad alone, and nothing else with it
        mesh = [g for g, kind in geoms.items() if kind == geoms[pad] and g != pad]
        filters.ExcludeBetween(drake.GeometrySet(mesh), drake.GeometrySet([obj]))
        filters.ExcludeBetween(drake.GeometrySet([pad]), drake.GeometrySet([g for g in geoms if g not in (obj, pad)]))
    if hulls:  # a piece down: its hull on the table and the hand, its field on the object, the walls, the pieces
        walls = [g for g, kind in geoms.items() if kind == "solid" and g not in hulls and g not in fields]
        table = next(g for g, kind in geoms.items() if kind == "table")
        filters.ExcludeWithin(drake.GeometrySet(hulls))
        filters.ExcludeBetween(drake.GeometrySet(hulls), drake.GeometrySet(fields + walls + [obj]))
        filters.ExcludeBetween(drake.GeometrySet(fields), drake.GeometrySet([table]))
        filters.ExcludeBetween(drake.GeometrySet(fields), hand_set)
    scene_graph.collision_filter_manager().Apply(filters)

    palm_source = builder.AddSystem(drake.TrajectorySource(palm_trajectory, 1))
    builder.Connect(palm_source.get_output_port(), plant.get_desired_state_input_port(hand))
    jaw_source = builder.AddSystem(drake.TrajectorySource(jaw_trajectory, 1))
    builder.Connect(jaw_source.get_output_port(), plant.get_desired_state_input_port(gripper))
    diagram = builder.Build()
    simulator = drake.Simulator(diagram)
    return DrakeWorld(world, diagram, plant, scene_graph, simulator, np.asarray(palm_base, dtype=float), palm_source,
                      jaw_source, bodies, joints, jaw_joints, geoms, pads)


def _add_table(drake, plant, world: WorldDescription, geoms: dict) -> None:
    """The table, a compliant half space at its height, and the fixed solids (point contact)."""
    table = drake.ProximityProperties()
    mu_table = geometry_friction(world.table_friction)
    drake.AddContactMaterial(None, 2 * POINT_STIFFNESS, drake.CoulombFriction(mu_table, mu_table), table)
    table.AddProperty("material", "relaxation_time", TABLE_RELAXATION_TIME)
    drake.AddCompliantHydroelasticPropertiesForHalfSpace(TABLE_SLAB, TABLE_MODULUS, table)
    gid = plant.RegisterCollisionGeometry(plant.world_body(), drake.RigidTransform([0.0, 0.0, world.table_height]),
                                          drake.HalfSpace(), "table", table)
    geoms[gid] = "table"
    for solid in world.solids:
        shape, pose = _shape(drake, solid)
        gid = plant.RegisterCollisionGeometry(plant.world_body(), pose, shape, solid.name,
                                              _properties(drake, solid, geometry_friction(solid.friction), "rigid"))
        geoms[gid] = "solid"


def _add_palm(drake, plant, world: WorldDescription, palm_base: NDArray, geoms: dict):
    """The palm on six joints (three slides, three turns after palm_base), the housing on it: the
    hand's model instance, the palm's body and the joints."""
    X = drake.RigidTransform
    hand = plant.AddModelInstance("hand")
    previous, joints = plant.world_body(), []
    for k, name in enumerate(("palm_x", "palm_y", "palm_z", "palm_a", "palm_b")):
        link = plant.AddRigidBody(name + "_link", hand, drake.SpatialInertia.Zero())
        if k < 3:
            joint = drake.PrismaticJoint(name, previous.body_frame(), link.body_frame(), np.eye(3)[k])
        else:
            parent = previous.body_frame() if k > 3 else plant.AddFrame(drake.FixedOffsetFrame(
                "palm_base", previous.body_frame(), X(drake.RotationMatrix(palm_base), np.zeros(3))))
            joint = drake.RevoluteJoint(name, parent, link.body_frame(), [0.0, 1.0, 0.0] if k == 3 else [1.0, 0.0, 0.0])
        joints.append(plant.AddJoint(joint))
        previous = link
    palm = plant.AddRigidBody("palm", hand, _inertia(drake, (world.palm,)))
    joints.append(plant.AddJoint(drake.RevoluteJoint("palm_c", previous.body_frame(), palm.body_frame(),
                                                     [0.0, 0.0, 1.0])))
    shape, pose = _shape(drake, world.palm)
    # the housing carries no friction, as in MuJoCo's model (its geom's default, 0)
    gid = plant.RegisterCollisionGeometry(palm, pose, shape, "palm", _properties(drake, world.palm, 0.0, "compliant",
                                                                                  HOUSING_MODULUS))
    geoms[gid] = "palm"
    return hand, palm, joints


def _add_jaws(drake, plant, world: WorldDescription, palm, geoms: dict):
    """The two jaws sliding on the palm, coupled, each digit on its bend spring: the gripper's
    model instance, the bodies by name (the palm's too), the jaws' joints by jaw and the digits'
    pads (GeometryId -> PAD_GRADIENT): the thumb's (thumb_pad), and a flat finger's (flat_pad)."""
    X = drake.RigidTransform
    gripper = plant.AddModelInstance("gripper")
    bodies = {"palm": palm}
    jaw_joints, pads = {}, {}
    for jaw in world.jaws:
        carriage = plant.AddRigidBody(jaw.name + "_jaw", gripper, drake.SpatialInertia.MakeFromCentralInertia(
            jaw.mass, np.zeros(3), drake.RotationalInertia(*jaw.inertia)))
        jaw_joints[jaw.name] = plant.AddJoint(drake.PrismaticJoint(
            jaw.joint_name, palm.body_frame(), carriage.body_frame(), jaw.axis, jaw.lower, jaw.upper))
        digit = jaw.digit
        body = plant.AddRigidBody(digit.name, gripper, _inertia(drake, digit.geoms))
        w, x, y, z = digit.quat
        bend = plant.AddJoint(drake.RevoluteJoint(
            f"{digit.name}_bend", plant.AddFrame(drake.FixedOffsetFrame(
                f"{digit.name}_base", carriage.body_frame(),
                X(drake.RotationMatrix(drake.Quaternion(w, x, y, z)), digit.position))),
            body.body_frame(), [0.0, 1.0, 0.0], digit.bend.damping))
        plant.AddForceElement(drake.RevoluteSpring(bend, 0.0, digit.bend.stiffness))
        for geom in digit.geoms:
            shape, pose = _shape(drake, geom)
            gid = plant.RegisterCollisionGeometry(body, pose, shape, geom.name, _properties(
                drake, geom, geometry_friction(geom.friction), None))
            geoms[gid] = geom.name
        if jaw is world.thumb:
            pad = thumb_pad(world) if THUMB_PAD else None
        else:
            pad = flat_pad(world) if world.dome is None else None
        if pad is not None:
            half, pose, modulus = pad
            geom = digit.geoms[0]
            props = _properties(drake, geom, geometry_friction(geom.friction), "compliant", modulus,
                                relaxation=OBJECT_RELAXATION_TIME)
            gid = plant.RegisterCollisionGeometry(body, drake.RigidTransform(pose), drake.Box(*(2 * half)),
                                                  f"{digit.name}_pad", props)
            geoms[gid], pads[gid] = geom.name, PAD_GRADIENT
        bodies[jaw.name + "_jaw"], bodies[digit.name] = carriage, body
    plant.AddCouplerConstraint(jaw_joints["thumb"], jaw_joints["finger"], -1.0, 0.0)
    return gripper, bodies, jaw_joints, pads


def flat_pad(world: WorldDescription) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """A flat finger's pad, its contact with the object in Drake (docs/model.md 11.19): a box as
    deep as the finger's tip is thick, as wide as the finger and as long, its face through the
    finger's tip edge and leaning back from it toward the palm by FACE_DRAFT (as a rounded
    finger's face leans back behind its dome), so that at psi above -FACE_DRAFT it touches the
    object along its tip edge alone. Its half sizes (3,), its pose in the finger's frame (4x4, m:
    x behind the face, z from the palm to the tip) and its hydroelastic modulus (Pa): PAD_GRADIENT
    over its half depth."""
    g = world.spec.gripper
    half = np.array([g.finger_tip_thickness / 2, g.width / 2, g.finger_length / 2])
    c, s = math.cos(FACE_DRAFT), math.sin(FACE_DRAFT)
    lean = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]).T  # (0, 0, -1) toward (sin, 0, -cos)
    pose = np.eye(4)
    pose[:3, :3] = lean
    pose[:3, 3] = np.array([0.0, 0.0, g.finger_length]) + lean @ np.array([half[0], 0.0, -half[2]])
    return half, pose, PAD_GRADIENT * float(half.min())


def thumb_pad(world: WorldDescription) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """The thumb's pad, its contact with the object in Drake (docs/model.md 11.19): a box behind
    the thumb's face, as deep as its tip is thick, as wide as the thumb and as long, its face the
    thumb's face (x = 0 of the thumb's frame, flush), compliant as a flat finger's pad (flat_pad),
    so that the object's end meets it in a patch that carries a couple across the plane, as the
    face's several contacts do in MuJoCo. Its half sizes (3,), its pose in the thumb's frame (4x4,
    m: x from the face into the thumb is -x, z from the palm to the tip) and its hydroelastic
    modulus (Pa)."""
    g = world.spec.gripper
    half = np.array([g.thumb_tip_thickness / 2, g.width / 2, g.thumb_length / 2])
    pose = np.eye(4)
    pose[:3, 3] = np.array([-half[0], 0.0, half[2]])
    return half, pose, PAD_GRADIENT * float(half.min())


def _add_object(drake, plant, world: WorldDescription, geoms: dict):
    """The object, a free rigid body with its friction set per pair (OBJECT_FRICTION); its body."""
    objects = plant.AddModelInstance("object")
    obj = plant.AddRigidBody("object", objects, _inertia(drake, (world.object.geom,)))
    shape, pose = _shape(drake, world.object.geom, patches=True)
    gid = plant.RegisterCollisionGeometry(obj, pose, shape, "object", _properties(
        drake, world.object.geom, OBJECT_FRICTION, "rigid", relaxation=OBJECT_RELAXATION_TIME))
    geoms[gid] = "object"
    return obj


def _add_placed(drake, plant, body: FreeBody, geoms: dict):
    """A piece already down: a free body (its own model instance) starting at its pose, its mass
    from its density over its hull, with two contact geometries (the module: which pairs each
    meets is set by build's filters): its hull, rigid hydroelastic, with the object's coefficient
    (OBJECT_FRICTION), and its field (placed_field; Drake's compliant convex where its solid is
    no prism), compliant hydroelastic, with the solids' pair coefficient (geometry_friction). Its
    body, and the two GeometryIds."""
    instance = plant.AddModelInstance(body.name)
    rigid = plant.AddRigidBody(body.name, instance, _inertia(drake, (body.geom,)))
    mu = geometry_friction(body.geom.friction)
    shape, pose = _shape(drake, body.geom, patches=True)
    # the hull carries the object's coefficient, so that the piece lies on the table with the
    # object's pair coefficient there (the solids' pair coefficient is the table's, mu_G)
    hull = plant.RegisterCollisionGeometry(rigid, pose, shape, body.name, _properties(
        drake, body.geom, OBJECT_FRICTION, "rigid", relaxation=OBJECT_RELAXATION_TIME))
    field_ = placed_field(body.geom.shape.vertices)
    if field_ is None:
        modulus = PAD_GRADIENT * float(np.ptp(body.geom.shape.vertices[:, 2])) / 2
        shape, pose = _shape(drake, body.geom)  # a compliant field: Drake's Convex, never a triangulated hull
    else:
        points, tets, modulus = field_
        shape = drake.Mesh(drake.InMemoryMesh(mesh_file=drake.MemoryFile(
            _vtk(points, tets), ".vtk", body.name + ".vtk")))
    compliant = plant.RegisterCollisionGeometry(rigid, pose, shape, body.name + "_field", _properties(
        drake, body.geom, mu, "compliant", modulus, relaxation=OBJECT_RELAXATION_TIME))
    geoms[hull] = geoms[compliant] = "solid"
    plant.SetDefaultFloatingBaseBodyPose(rigid, drake.RigidTransform(drake.RotationMatrix(body.pose[:3, :3]),
                                                                     body.pose[:3, 3]))
    return rigid, hull, compliant


def placed_field(vertices: NDArray) -> tuple[NDArray[np.float64], NDArray[np.int64], float] | None:
    """A prism's tetrahedral mesh for compliant hydroelastic contact whose pressure rises at
    PAD_GRADIENT with the depth below the nearest face, as a box's does in Drake (the pads'):
    the outline's hull at the bottom and the top, and inset by half the thickness t at mid height,
    where every point lies t / 2 below the nearest face and the pressure is the modulus E =
    PAD_GRADIENT t / 2. Between them: a wedge under each side face, a slab under the bottom and one
    under the top (each cut into prisms about the outline's centroid), every tetrahedron between
    the surface (pressure 0) and the mid layer (E), so that the linear pressure in it is E times
    the depth below its face over t / 2. vertices (N, 3): the prism's, two outlines at two heights
    (m, the body's frame). Returns the mesh's points (K, 3), its tetrahedra (M, 4: positive
    volume) and E (Pa); None where vertices are no prism, or the outline is too narrow for the
    inset (a side vanishes)."""
    from scipy.spatial import ConvexHull

    z = vertices[:, 2]
    lo, hi = float(z.min()), float(z.max())
    t = hi - lo
    if t <= 0 or not np.all(np.isclose(z, lo, atol=1e-9 + 1e-6 * t) | np.isclose(z, hi, atol=1e-9 + 1e-6 * t)):
        return None
    xy = vertices[:, :2]
    try:
        ring = xy[ConvexHull(xy).vertices]  # counter-clockwise
    except Exception:  # noqa: BLE001 (a degenerate outline: qhull's error)
        return None
    n = len(ring)
    edges = np.roll(ring, -1, axis=0) - ring
    inward = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
    h = t / 2
    # the inset corner k: on the lines of sides k - 1 and k moved inward by h
    prev_n, next_n = np.roll(inward, 1, axis=0), inward
    bisector = prev_n + next_n
    scale = h / np.einsum("ij,ij->i", bisector, next_n)
    mid = ring + bisector * scale[:, None]
    inset_edges = np.roll(mid, -1, axis=0) - mid
    if np.any(np.einsum("ij,ij->i", inset_edges, edges) <= 1e-12):
        return None
    bottom = np.column_stack([ring, np.full(n, lo)])
    top = np.column_stack([ring, np.full(n, hi)])
    middle = np.column_stack([mid, np.full(n, lo + h)])
    centres = np.array([[*ring.mean(axis=0), lo], [*ring.mean(axis=0), hi], [*mid.mean(axis=0), lo + h]])
    points = np.vstack([bottom, top, middle, centres])
    B, T, M = np.arange(n), n + np.arange(n), 2 * n + np.arange(n)
    cb, ct, cm = 3 * n, 3 * n + 1, 3 * n + 2
    tets = []
    for k in range(n):
        j = (k + 1) % n
        tets += _prism_tets((cb, B[k], B[j]), (cm, M[k], M[j]))  # under the bottom
        tets += _prism_tets((ct, T[k], T[j]), (cm, M[k], M[j]))  # under the top
        tets += _prism_tets((B[k], M[k], T[k]), (B[j], M[j], T[j]))  # under side k
    tets = np.array(tets, dtype=np.int64)
    a, b, c, d = (points[tets[:, i]] for i in range(4))
    negative = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    return points, tets, PAD_GRADIENT * h


def _prism_tets(a: tuple[int, int, int], b: tuple[int, int, int]) -> list[tuple[int, int, int, int]]:
    """A triangular prism (a[k] over b[k]) cut into three tetrahedra, each of its quadrilateral
    faces cut along the diagonal through its smallest vertex index, so that prisms sharing a face
    cut it alike (the mesh conforms)."""
    v = list(a) + list(b)  # 0 1 2 / 3 4 5, k over k + 3
    first = int(np.argmin(v))
    # relabel so that the smallest is vertex 0: turn the triangles, and swap them if it is on b
    turn = first % 3
    order = [(turn + i) % 3 for i in range(3)]
    lower, upper = ([v[i] for i in order], [v[i + 3] for i in order])
    if first >= 3:
        lower, upper = upper, lower
    p0, p1, p2 = lower
    p3, p4, p5 = upper
    if min(p1, p5) < min(p2, p4):
        return [(p0, p1, p2, p5), (p0, p1, p5, p4), (p0, p4, p5, p3)]
    return [(p0, p1, p2, p4), (p0, p4, p2, p5), (p0, p4, p5, p3)]


def _vtk(points: NDArray, tets: NDArray) -> str:
    """A tetrahedral mesh as a legacy ASCII VTK unstructured grid (Drake's volume mesh file)."""
    lines = ["# vtk DataFile Version 3.0", "placed piece", "ASCII", "DATASET UNSTRUCTURED_GRID",
             f"POINTS {len(points)} double"]
    lines += [" ".join(f"{x:.17g}" for x in p) for p in points]
    lines.append(f"CELLS {len(tets)} {5 * len(tets)}")
    lines += ["4 " + " ".join(str(int(i)) for i in t) for t in tets]
    lines.append(f"CELL_TYPES {len(tets)}")
    lines += ["10"] * len(tets)
    return "\n".join(lines) + "\n"


def _add_actuators(drake, plant, world: WorldDescription, joints: list, jaw_joints: dict) -> None:
    """The palm's six joints and the servo, each a PD controller SAP applies implicitly."""
    hand_mass = world.palm.mass + sum(j.mass for j in world.jaws) + 0.05
    for k, joint in enumerate(joints):
        inertia = hand_mass if k < 3 else HAND_TURN_INERTIA
        kp = inertia * PALM_FREQUENCY ** 2
        actuator = plant.AddJointActuator(joint.name(), joint, math.inf)
        kd = 2 * PALM_DAMPING_RATIO * inertia * PALM_FREQUENCY
        actuator.set_controller_gains(drake.PdControllerGains(p=kp, d=kd))
    servo = world.servo
    actuator = plant.AddJointActuator("opening", jaw_joints["finger"], servo.gear * servo.force_limit)
    actuator.set_controller_gains(drake.PdControllerGains(p=servo.gear ** 2 * servo.stiffness,
                                                          d=servo.gear ** 2 * servo.damping))
