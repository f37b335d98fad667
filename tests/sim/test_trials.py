"""Trials executed in physics on real configurations (scene 12: a bottle for the Panda, a
medicine bottle for the suction UR5e, a cabinet door for the Flexiv)."""

import dataclasses

import numpy as np
import pytest

from momakitchen.scene.configuration import sample_scene
from momakitchen.scene.geometry import Footprint, overlaps
from momakitchen.sim.labels import label_configuration
from momakitchen.sim.trials import Stage, TrialRunner
from momakitchen.sim.world import World


@pytest.fixture(scope="module")
def scene():
    return sample_scene(12)


@pytest.fixture(scope="module")
def world(scene):
    w = World(scene.layout)
    yield w
    w.close()


@pytest.fixture(scope="module")
def bottle_labels(world, scene):
    cfg = scene.configurations[0]
    assert cfg.robot == "panda" and cfg.target.category == "bottle"
    return label_configuration(world, cfg)


def test_gripper_lifts_the_bottle_from_some_positions(bottle_labels, scene):
    labels = bottle_labels
    assert labels.outcomes.sum() >= 3
    ok = labels.stages == Stage.SUCCESS
    assert np.all(labels.moved[ok] >= 0.05), "success means the bottle rose >= 5 cm"
    # A base standing on an obstacle (its centre under the footprint) is a base collision.
    # (Bounding boxes overlapping is not enough: a round bin leaves its corners free.)
    cfg = scene.configurations[0]
    blocked = 0
    for (x, y), yaw, stage in zip(labels.positions, labels.yaws, labels.stages, strict=True):
        fp = Footprint(x, y, yaw, 0.55, 0.45)
        if any(overlaps(fp, Footprint(o.x, o.y, 0, 0.01, 0.01)) for o in cfg.obstacles):
            assert stage == Stage.BASE_COLLISION
            blocked += 1
    assert blocked > 0


def _successes(world, cfg, labels, never_close=False, **dyn):
    from momakitchen.sim.labels import set_target_dynamics

    world.load_configuration(cfg)
    set_target_dynamics(world, **dyn)
    runner = TrialRunner(world, cfg.robot)
    if never_close:
        runner.tool.close = runner.tool.open  # the only change: the fingers stay open
    try:
        idx = np.flatnonzero(labels.outcomes)[:4]
        return [runner.run(*labels.positions[i]) for i in idx]
    finally:
        runner.close()


def test_physics_matters_heavy_and_slippery_targets_fail(world, scene, bottle_labels):
    cfg = scene.configurations[0]
    heavy = _successes(world, cfg, bottle_labels, mass=50.0)
    assert heavy and all(r.stage == Stage.EXECUTION_FAILED for r in heavy)
    slippery = _successes(world, cfg, bottle_labels, friction=0.001)
    assert slippery and all(r.stage == Stage.EXECUTION_FAILED for r in slippery)
    normal = _successes(world, cfg, bottle_labels)
    assert all(r.success for r in normal)


def test_fingers_left_open_lift_nothing(world, scene, bottle_labels):
    """Control: the positions that succeed fail in execution if the gripper never closes
    (the bottle rises only because the fingers hold it)."""
    cfg = scene.configurations[0]
    results = _successes(world, cfg, bottle_labels, never_close=True)
    assert results and all(r.stage == Stage.EXECUTION_FAILED for r in results)
    assert all(r.moved < 0.01 for r in results)


def test_trials_do_not_leak_state(scene, bottle_labels):
    """A trial gives the same result whether or not other trials ran before it (two
    identically built worlds, one of which runs another trial first). Positions and
    velocities are restored exactly; PyBullet keeps some solver caches that its saved
    states do not cover, which moves the result by nanometres, not more."""
    cfg = scene.configurations[0]
    idx = np.flatnonzero(bottle_labels.outcomes)
    first, last = bottle_labels.positions[idx[0]], bottle_labels.positions[idx[-1]]
    results = []
    for sequence in ([last], [first, last]):
        with World(scene.layout) as w:
            w.load_configuration(cfg)
            runner = TrialRunner(w, cfg.robot)
            results.append([runner.run(*q) for q in sequence][-1])
    alone, after = results
    assert alone.success and after.success
    assert alone.moved == pytest.approx(after.moved, abs=1e-6)


def test_suction_lifts_only_by_contact(world, scene):
    cfg = scene.configurations[2]
    assert cfg.robot == "ur5e"
    labels = label_configuration(world, cfg)
    assert labels.outcomes.sum() >= 3
    assert np.all(labels.moved[labels.outcomes == 1] >= 0.05)


def test_labels_are_deterministic(scene, bottle_labels):
    """Bit for bit, in a freshly built world (the fixture's world has labelled other
    configurations in between)."""
    with World(scene.layout) as fresh:
        again = label_configuration(fresh, scene.configurations[0])
    for field in ("positions", "yaws", "stages", "moved"):
        assert np.array_equal(getattr(bottle_labels, field), getattr(again, field))


@pytest.mark.slow
def test_articulated_door_opens(world, scene):
    cfg = scene.configurations[1]
    assert cfg.target.is_articulated
    labels = label_configuration(world, cfg)
    assert labels.outcomes.sum() >= 3
    assert np.all(labels.moved[labels.outcomes == 1] >= np.radians(20) - 1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["panda", "flexiv", "ur5e", "xarm6", "realman", "elephant"])
def test_every_robot_succeeds_on_an_unobstructed_reachable_target(world, scene, robot):
    # The bottle of configuration 0, without obstacles, for each robot.
    cfg = dataclasses.replace(scene.configurations[0], robot=robot, obstacles=())
    labels = label_configuration(world, cfg)
    assert labels.outcomes.sum() >= 1, labels.stage_counts()


def test_resting_bodies_sleep_and_contact_wakes_them(world, scene):
    """During trials, bodies away from the target are not simulated (after the first step,
    which settles what the restored state left, their poses stay bit-identical; awake
    bodies resting on a surface creep by nanometres), yet a body put to sleep this way
    still moves when something hits it."""
    import pybullet as p

    cfg = scene.configurations[0]
    world.load_configuration(cfg)
    runner = TrialRunner(world, cfg.robot)
    try:
        c = world.client
        free = [b for b in runner._resting if p.getDynamicsInfo(b, -1, physicsClientId=c)[0] > 0]
        assert free, "scene 12's first configuration has free bodies away from the target"
        world.step(1)
        before = [p.getBasePositionAndOrientation(b, physicsClientId=c) for b in free]
        world.step(120)
        after = [p.getBasePositionAndOrientation(b, physicsClientId=c) for b in free]
        assert after == before
        # Something rolling into a resting body wakes it and pushes it.
        body = free[0]
        lo, hi = world.aabb(body)
        centre = (lo + hi) / 2
        ball = p.createMultiBody(
            1.0,
            p.createCollisionShape(p.GEOM_SPHERE, radius=0.05, physicsClientId=c),
            basePosition=[centre[0] - (hi[0] - lo[0]) / 2 - 0.1, centre[1], centre[2]],
            physicsClientId=c,
        )
        p.resetBaseVelocity(ball, [3.0, 0.0, 0.0], physicsClientId=c)
        world.step(60)
        moved = np.subtract(
            p.getBasePositionAndOrientation(body, physicsClientId=c)[0], before[0][0]
        )
        assert np.linalg.norm(moved) > 1e-3
        p.removeBody(ball, physicsClientId=c)
    finally:
        runner.close()
        world.load_configuration(cfg)


def _grid_labels(scene_id: int, config: int):
    """A configuration and its labels (every trial of its grid)."""
    scene = sample_scene(scene_id)
    cfg = scene.configurations[config]
    with World(scene.layout) as w:
        return cfg, label_configuration(w, cfg)


def test_a_gripper_lifts_a_pot_by_its_rim_and_level():
    """A lidless casserole (2 kg) is held at the rim, straddling the wall: it rises most of
    the 10 cm lift. Held by a side handle it turned about the fingers and rose ~4 cm."""
    cfg, labels = _grid_labels(2009, 7)
    assert cfg.robot == "panda" and cfg.target.category == "pot"
    ok = np.flatnonzero(labels.stages == Stage.SUCCESS)
    assert len(ok) and all(
        labels.grasps[i].startswith("rim") and labels.moved[i] > 0.07 for i in ok
    )


def test_suction_skips_grasps_too_narrow_to_seal_on():
    """The UR5e's cup never tries a pot's rim (a 4 mm edge) and lifts the pot by a handle."""
    cfg, labels = _grid_labels(2011, 7)
    assert cfg.robot == "ur5e" and cfg.target.category == "pot"
    executed = [i for i, g in enumerate(labels.grasps) if g]  # the trials that ran physics
    assert executed and all(
        labels.stages[i] == Stage.SUCCESS and labels.grasps[i].startswith("handle")
        for i in executed
    )


def test_labels_record_the_grasp_each_trial_executed(bottle_labels):
    """Which candidate succeeded, and which failed in physics: a name for every trial that
    reached physics, none for the others; the summary counts them per candidate."""
    labels = bottle_labels
    ran = (labels.stages == Stage.SUCCESS) | (labels.stages == Stage.EXECUTION_FAILED)
    assert len(labels.grasps) == len(labels.stages)
    assert all(bool(g) == bool(r) for g, r in zip(labels.grasps, ran, strict=True))
    counts = labels.summary()["grasps"]
    assert sum(c["success"] for c in counts.values()) == int(labels.outcomes.sum())
    assert sum(sum(c.values()) for c in counts.values()) == int(ran.sum())
    assert set(counts) <= {"side+x", "side-x", "side+y", "side-y", "top"}
