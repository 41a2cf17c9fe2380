"""Worlds the plan does not know (sim.world, docs/model.md 11.16): each key changes the compiled
MuJoCo model by what it says and nothing else, a pyramidal cone's contact forces are read as the
normal forces they are, bad keys and values are refused naming them, and a run records its world."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from conftest import run_cli
from ungrasp_ompl import Scene
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.scene.perturbation import TrialParams
from ungrasp_ompl.mechanics.release import pyramid_reach
from ungrasp_ompl.sim.landing import LANDING_FRICTION_RANGE, landing_draw
from ungrasp_ompl.sim.model import build_mjcf, model_ids
from ungrasp_ompl.sim.spec import SOLREF, SimObject
from ungrasp_ompl.sim.trial import _start, _Watch, trial_spec
from ungrasp_ompl.sim.world import Cone, World

from conftest import SCENES
from ungrasp_ompl.planning import plan
from ungrasp_ompl.robot.pipeline import execute
from ungrasp_ompl.sim.setup import trial_setup


@pytest.fixture(scope="module")
def pick():
    """The guitar pick's lattice plan, executed: (scene, plan, execution)."""
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    result = plan(scene, planner="lattice")
    return scene, result, execute(scene, result)


def _setup(pick):
    scene, result, ex = pick
    return trial_setup(scene, result, ex.trajectory, ex.robot)


def _compiled(setup, params=TrialParams()):
    spec = trial_spec(setup, params)
    model = mujoco.MjModel.from_xml_string(build_mjcf(spec))
    return spec, model, model_ids(model)


def test_each_key_changes_the_compiled_world_by_its_factor(pick):
    """Friction per pair, the free object's mass, the cone (and its step, sim.pyramidal_timestep),
    the contacts' time constant and the jaws' force limit of the compiled model, against the
    nominal world's, key by key; the other parts of the model stay as they were."""
    setup = _setup(pick)
    setup = replace(setup, sim=replace(setup.sim, pyramidal_timestep=setup.sim.timestep / 4))  # told apart
    _, nominal, ids = _compiled(setup)
    fr = {g: nominal.geom_friction[g][0] for g in (ids.table_geom, *ids.finger_geoms, *ids.thumb_geoms)}
    mass = nominal.body_mass[ids.object_body]
    force = nominal.actuator_forcerange[ids.actuator].copy()
    digits = (*ids.finger_geoms, *ids.thumb_geoms)
    cases = {
        World(friction=1.3): lambda m: all(m.geom_friction[g][0] == pytest.approx(1.3 * fr[g]) for g in fr),
        World(friction_table=0.7): lambda m: (m.geom_friction[ids.table_geom][0] == pytest.approx(0.7 * fr[ids.table_geom])
                                              and all(m.geom_friction[g][0] == pytest.approx(fr[g]) for g in digits)),
        World(friction=0.5, friction_digits=2.0): lambda m: (
            m.geom_friction[ids.table_geom][0] == pytest.approx(0.5 * fr[ids.table_geom])
            and all(m.geom_friction[g][0] == pytest.approx(fr[g]) for g in digits)),
        World(density=2.0): lambda m: m.body_mass[ids.object_body] == pytest.approx(2.0 * mass),
        World(cone=Cone.PYRAMIDAL): lambda m: (m.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL
                                               and m.opt.timestep == pytest.approx(setup.sim.pyramidal_timestep)),
        World(stiffness=0.25): lambda m: m.geom_solref[ids.table_geom][0] == pytest.approx(2 * SOLREF[0]),
        World(jaw_force=1.5): lambda m: np.allclose(m.actuator_forcerange[ids.actuator], 1.5 * force),
    }
    assert nominal.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and nominal.geom_solref[ids.table_geom][0] == SOLREF[0]
    assert nominal.opt.timestep == pytest.approx(setup.sim.timestep)
    for world, holds in cases.items():
        _, model, _ = _compiled(replace(setup, world=world))
        assert holds(model), world
        untouched = [k for k, v in world.to_dict().items() if v == World().to_dict()[k]]
        if "density" in untouched:
            assert model.body_mass[ids.object_body] == pytest.approx(mass)
        if "jaw_force" in untouched:
            assert np.allclose(model.actuator_forcerange[ids.actuator], force)


def test_a_world_that_sets_a_pairs_friction_fixes_it_and_the_other_errors_compose(pick):
    """Where the world sets a pair's friction, the trial's drawn friction factor does not apply to
    that pair (the world's factor is its error); pairs the world leaves alone keep their draw, and
    the other worlds' factors multiply; the compounding rule multiplies every draw."""
    base = _setup(pick)
    nominal = base.spec.friction
    drawn = TrialParams(friction_scale=(0.9, 0.8, 0.85))
    cases = {  # world: factors applied at (G, A, B), then under the compounding rule
        World(friction=0.7): ((0.7, 0.7, 0.7), (0.7 * 0.9, 0.7 * 0.8, 0.7 * 0.85)),
        World(friction_table=0.7): ((0.7, 0.8, 0.85), (0.7 * 0.9, 0.8, 0.85)),
        World(friction_digits=1.3): ((0.9, 1.3, 1.3), (0.9, 1.3 * 0.8, 1.3 * 0.85)),
        World(density=2.0): ((0.9, 0.8, 0.85), (0.9, 0.8, 0.85)),
    }
    for world, rules in cases.items():
        for compounded, (g, a, b) in zip((False, True), rules):
            spec = trial_spec(replace(base, world=world, friction_draw_in_world=compounded), drawn)
            got = (spec.friction.table / nominal.table, spec.friction.finger / nominal.finger,
                   spec.friction.thumb / nominal.thumb, spec.friction.solids / nominal.solids)
            assert got == pytest.approx((g, a, b, g)), (world, compounded)


@pytest.mark.parametrize("cone", list(Cone))
def test_a_resting_objects_contact_forces_carry_its_weight_under_either_cone(pick, cone):
    """A plate resting on the table: the normal forces the trial reads off its contacts (the
    first constraint row under elliptic cones, the sum of the edge forces under pyramidal ones)
    add up to its weight, and agree with MuJoCo's own mj_contactForce contact by contact."""
    plate = SimObject(np.array([[0.0, -0.01], [0.03, -0.01], [0.03, 0.01], [0.0, 0.01]]), 0.002, 1250.0)
    spec = replace(_setup(pick).spec, obj=plate, cone=str(cone), solids=(), placed=())
    model = mujoco.MjModel.from_xml_string(build_mjcf(spec))
    data = mujoco.MjData(model)
    ids = model_ids(model)
    q = model.jnt_qposadr[model.body_jntadr[ids.object_body]]
    data.qpos[q:q + 3] = (0.5, 0.5, 0.0)  # far from the gripper, which hangs at the origin
    palm_q = model.jnt_qposadr[model.body_jntadr[ids.palm_body]]
    data.qpos[palm_q:palm_q + 3] = (0.0, 0.0, 0.5)
    data.mocap_pos[ids.palm_mocap] = (0.0, 0.0, 0.5)
    mujoco.mj_step(model, data, nstep=3000)
    watch = _Watch(model, ids)
    normals, own = [], []
    f6 = np.zeros(6)
    for i in range(data.ncon):
        if ids.object_geom in data.contact.geom[i]:
            normals.append(watch._normal(data.efc_force, int(data.contact.efc_address[i])))
            mujoco.mj_contactForce(model, data, i, f6)
            own.append(f6[0])
    weight = model.body_mass[ids.object_body] * 9.81
    assert len(normals) >= 3
    assert sum(normals) == pytest.approx(weight, rel=1e-3)
    assert np.allclose(normals, own, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("heading_deg, cone, slides_at", [
    (0.0, Cone.PYRAMIDAL, 1.0), (45.0, Cone.PYRAMIDAL, 1 / math.sqrt(2)), (30.0, Cone.PYRAMIDAL, None),
    (45.0, Cone.ELLIPTIC, 1.0)])
def test_the_tables_pyramid_lies_along_the_worlds_axes_and_holds_its_reach(pick, heading_deg, cone, slides_at):
    """A plate resting on the table, turned by heading about the vertical and pushed along its own
    x axis: the table's contact frames keep their tangents along the world's x and y axes, and the
    push the plate holds is pyramid_reach of the heading times mu times its weight under pyramidal
    cones (the whole of it under Coulomb's cone): it stays put at 0.9 of that and slides at 1.1."""
    plate = SimObject(np.array([[0.0, -0.01], [0.03, -0.01], [0.03, 0.01], [0.0, 0.01]]), 0.002, 1250.0)
    spec = replace(_setup(pick).spec, obj=plate, cone=str(cone), solids=(), placed=())
    model = mujoco.MjModel.from_xml_string(build_mjcf(spec))
    ids = model_ids(model)
    a = math.radians(heading_deg)  # from the world's x axis
    reach = pyramid_reach(math.cos(a), math.sin(a)) if cone is Cone.PYRAMIDAL else 1.0
    if slides_at is not None:
        assert reach == pytest.approx(slides_at)
    mu = model.geom_friction[ids.table_geom][0]
    weight = model.body_mass[ids.object_body] * 9.81
    moved = []
    for share in (0.9, 1.1):
        data = mujoco.MjData(model)
        q = model.jnt_qposadr[model.body_jntadr[ids.object_body]]
        data.qpos[q:q + 3] = (0.5, 0.5, 0.0)  # far from the gripper, which hangs at the origin
        data.qpos[q + 3:q + 7] = (math.cos(a / 2), 0.0, 0.0, math.sin(a / 2))
        palm_q = model.jnt_qposadr[model.body_jntadr[ids.palm_body]]
        data.qpos[palm_q:palm_q + 3] = (0.0, 0.0, 0.5)
        data.mocap_pos[ids.palm_mocap] = (0.0, 0.0, 0.5)
        mujoco.mj_step(model, data, nstep=2000)  # at rest
        for i in range(data.ncon):
            if ids.table_geom in data.contact.geom[i]:
                tangents = data.contact.frame[i].reshape(3, 3)[1:]
                assert np.allclose(np.abs(tangents), [[0, 1, 0], [1, 0, 0]], atol=1e-9)
        start = data.xpos[ids.object_body].copy()
        push = share * reach * mu * weight
        data.xfrc_applied[ids.object_body, :2] = push * np.array([math.cos(a), math.sin(a)])
        duration = 0.2  # s
        mujoco.mj_step(model, data, nstep=round(duration / model.opt.timestep))
        moved.append(float(np.linalg.norm(data.xpos[ids.object_body][:2] - start[:2])))
    # sliding, the tenth of the push beyond the reach accelerates the plate: 0.1 reach mu g t^2 / 2
    assert moved[0] < 2e-5
    assert moved[1] > 0.5 * (0.1 * reach * mu * 9.81) * duration ** 2 / 2


def test_every_pyramid_lies_along_the_plane_only_where_gb_lies_along_a_world_axis(pick):
    """MuJoCo builds the contacts' frames from directions fixed in the world: in the pick's trial as
    shipped (GB along the world's -y axis) the table's, the thumb's and the finger's frames each
    have a tangent within 2 deg of the manipulation plane's normal; with the target turned 45 deg
    about the vertical, none is nearer than 40 deg to it."""
    import yaml

    doc = yaml.safe_load((SCENES / "guitar_pick.yaml").read_text())
    doc["object"]["target"]["yaw_deg"] = doc["object"]["target"].get("yaw_deg", 0.0) + 45.0
    turned = Scene.from_dict(doc)
    result = plan(turned, planner="lattice")
    ex = execute(turned, result)
    for scene, setup, (low, high) in ((pick[0], _setup(pick), (0.0, 2.0)),
                                      (turned, trial_setup(turned, result, ex.trajectory, ex.robot), (40.0, 45.0))):
        _, model, data, ids, _, _ = _start(setup, TrialParams(), [])
        mujoco.mj_step(model, data, nstep=200)
        normal = scene.plane.frame[:3, 1]
        kinds = set()
        for i in range(data.ncon):
            tangents = data.contact.frame[i].reshape(3, 3)[1:]
            off = min(math.degrees(math.acos(min(1.0, abs(float(t @ normal))))) for t in tangents)
            assert low <= off <= high
            kinds |= {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in data.contact.geom[i]}
        assert {"table", "thumb", "finger_tip"} <= kinds


@pytest.mark.parametrize("items, field", [
    (["friction=-1"], "world.friction"), (["friction=nan"], "world.friction"), (["density=0"], "world.density"),
    (["stiffness=2"], "world.stiffness"), (["cone=round"], "world.cone"), (["wind=3"], "world.wind"),
    (["friction"], "world"), (["friction=0.7", "friction=0.8"], "world.friction"), (["jaw_force=x"], "world.jaw_force"),
])
def test_a_bad_world_is_refused_naming_its_key(items, field):
    with pytest.raises(InputError) as err:
        World.parse(items)
    assert err.value.field == field


def test_a_world_parses_and_describes_itself():
    world = World.parse(["friction=0.7", "cone=pyramidal", "stiffness=0.25"])
    assert world == World(friction=0.7, cone=Cone.PYRAMIDAL, stiffness=0.25)
    assert world.time_constant_factor == pytest.approx(2.0)
    assert World.parse([]).nominal and not world.nominal
    assert World(**{k: v for k, v in world.to_dict().items()}) == world


def test_the_aims_worlds_span_the_friction_range_and_both_cones():
    """The expected landing's pairs (sim.landing.landing_draw): each pair's two worlds scale the
    friction by f and 2 - f within 1 +- LANDING_FRICTION_RANGE, share a cone, and the cones
    alternate from pair to pair; the errors are the `paper` draw and its mirror."""
    from ungrasp_ompl.scene.perturbation import PRESETS

    factors = []
    for k in range(16):
        (p, w), (m, v) = landing_draw(k)
        assert w.cone is v.cone is (Cone.ELLIPTIC if k % 2 == 0 else Cone.PYRAMIDAL)
        assert w.friction + v.friction == pytest.approx(2.0)
        assert abs(w.friction - 1.0) <= LANDING_FRICTION_RANGE
        assert m == PRESETS["paper"].mirrored(p)
        factors.append(w.friction)
    assert min(factors) < 0.85 and max(factors) > 1.15  # the draws reach across the range


@pytest.mark.slow
def test_simulate_runs_a_kept_plan_in_another_world_and_records_it(tmp_path):
    """The issue's command on a plan written by plan --export: the trials run in the world given,
    the hand aimed as the plan's own placement aims it (the same aim as in the nominal world),
    and trials.csv and summary.json record the world."""
    plan_dir, nominal, other = tmp_path / "plan", tmp_path / "nominal", tmp_path / "world"
    assert run_cli("plan", "guitar_pick", "--seed", "1", "--out", str(plan_dir)).returncode == 0
    r = run_cli("simulate", "guitar_pick", "--plan", str(plan_dir), "--trials", "2", "--seed", "3", "--out", str(nominal))
    assert r.returncode == 0, r.stderr
    r = run_cli("simulate", "guitar_pick", "--plan", str(plan_dir), "--world", "friction=0.7", "--world", "cone=pyramidal",
                "--trials", "2", "--seed", "3", "--out", str(other))
    assert r.returncode == 0, r.stderr
    summary = json.loads((other / "summary.json").read_text())
    assert summary["world"] == World(friction=0.7, cone=Cone.PYRAMIDAL).to_dict()
    assert json.loads((nominal / "summary.json").read_text())["world"] == World().to_dict()
    assert summary["aim_m"] == json.loads((nominal / "summary.json").read_text())["aim_m"]
    gb = Scene.from_file("guitar_pick").plane.frame[:3, 0]  # GB on the table; the table's pyramid lies along x and y
    assert summary["gb_heading_rad"] == pytest.approx(math.atan2(gb[1], gb[0]), abs=1e-6)
    assert summary["table_pyramid_reach_along_gb"] == pytest.approx(
        pyramid_reach(math.cos(summary["gb_heading_rad"]), math.sin(summary["gb_heading_rad"])))
    assert json.loads((nominal / "summary.json").read_text())["table_pyramid_reach_along_gb"] is None
    assert summary["environment"]["packages"]["mujoco"] == mujoco.__version__  # what the trials ran on
    rows = list(csv.DictReader((other / "trials.csv").open()))
    assert len(rows) == 2 and all(float(r["world_friction"]) == 0.7 and r["world_cone"] == "pyramidal" for r in rows)
    model = mujoco.MjModel.from_xml_path(str(other / "model.xml"))  # trial 0's world, as it ran
    assert model.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL
    # the world sets every pair's friction, so trial 0 meets x0.7 whatever its drawn factor (decision 0100)
    assert float(rows[0]["p_friction_scale_G"]) < 1.0
    assert math.isclose(0.7 * Scene.from_file("guitar_pick").mu_contacts[0],
                        model.geom_friction[model_ids(model).table_geom][0], rel_tol=1e-6)
