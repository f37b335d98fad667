"""External asset folders in PartNet-Mobility layout: scanning, loading, broken files."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from asset_helpers import body_aabb, load

from momakitchen.assets import get_category
from momakitchen.assets.external import (
    ExternalParams,
    build_external,
    clear_external_assets,
    load_folder,
    register_external_assets,
    sample_external,
    scan_folder,
)
from momakitchen.assets.registry import Envelope
from momakitchen.errors import MomaError

BOX = """<?xml version="1.0"?>
<robot name="box">
  <link name="base">
    <inertial><mass value="2"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>
    </inertial>
    <collision><origin xyz="0.5 0.2 0.3"/><geometry><box size="0.4 0.3 0.2"/></geometry>
    </collision>
  </link>
</robot>
"""

CABINET = """<?xml version="1.0"?>
<robot name="cab">
  <link name="base">
    <inertial><mass value="20"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
    <collision><origin xyz="0 0 0.4"/><geometry><box size="1.0 0.5 0.8"/></geometry></collision>
  </link>
  <link name="door">
    <inertial><origin xyz="0.25 0.01 0.35"/><mass value="2"/>
      <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial>
    <collision><origin xyz="0.25 0.01 0.35"/><geometry><box size="0.5 0.02 0.7"/></geometry>
    </collision>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="base"/><child link="door"/><origin xyz="-0.5 0.25 0.05"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="1.57" effort="10" velocity="1"/>
  </joint>
</robot>
"""


def _folder(root: Path) -> Path:
    bottle = BOX.replace("0.4 0.3 0.2", "0.08 0.08 0.3")  # PartNet-like: not metric
    for cat, ident, text in [
        ("StorageFurniture", "101", CABINET),
        ("Bottle", "7", bottle),
        ("trolley", "a", BOX),
        ("Unrelated", "1", BOX),
    ]:
        d = root / cat / ident
        d.mkdir(parents=True)
        (d / "mobility.urdf").write_text(text)
    return root


def test_scan_maps_partnet_and_own_names(tmp_path):
    assets = scan_folder(_folder(tmp_path))
    assert [(a.category, a.source_category, a.asset_id) for a in assets] == [
        ("bottle", "Bottle", "7"),
        ("cabinet", "StorageFurniture", "101"),
        ("trolley", "trolley", "a"),
    ]


def test_tiny_folder_loads_in_our_frames(tmp_path, client):
    models = {m.category: m for m in load_folder(_folder(tmp_path))}
    bottle = models["bottle"]
    assert bottle.size == pytest.approx((0.08, 0.08, 0.3), abs=0.003)
    body = load(bottle, client, fixed=True)
    lo, hi = body_aabb(body, client)
    assert (lo[:2] + hi[:2]) / 2 == pytest.approx([0.0, 0.0], abs=0.003)  # footprint centre
    assert lo[2] == pytest.approx(0.0, abs=0.003)
    cab = models["cabinet"]
    (art,) = cab.articulations
    assert (art.joint, art.joint_type, art.part, art.open_direction) == (
        "hinge",
        "revolute",
        "door",
        1,
    )
    assert art.limit == pytest.approx(1.57)
    assert art.handle.link == "door"
    body = load(cab, client, fixed=True)
    lo, hi = body_aabb(body, client)
    assert lo[1] == pytest.approx(0.0, abs=0.003) and lo[2] == pytest.approx(0.0, abs=0.003)
    assert (lo[0] + hi[0]) / 2 == pytest.approx(0.0, abs=0.003)


def test_furniture_is_scaled_into_its_envelope(tmp_path, client):
    assets = scan_folder(_folder(tmp_path))
    params = sample_external(assets, "cabinet", np.random.default_rng(0), Envelope(0.6, 0.6, 0.9))
    back = ExternalParams.from_dict(json.loads(json.dumps(dataclasses.asdict(params))))
    assert back == params
    model = build_external(params)
    assert model.scale == pytest.approx(0.6 / 1.0, abs=0.003)  # width is the binding side
    assert max(np.asarray(model.size) - (0.6, 0.6, 0.9)) <= 1e-6
    body = load(model, client, fixed=True)
    lo, hi = body_aabb(body, client)
    assert hi - lo == pytest.approx(model.size, abs=0.004)


@pytest.mark.parametrize(
    "text, match",
    [
        ("<robot name='x'><link name='a'>", "cannot parse"),
        (
            "<robot name='x'><link name='a'><visual><geometry>"
            "<mesh filename='gone.obj'/></geometry>"
            "</visual></link></robot>",
            "gone.obj",
        ),
    ],
)
def test_broken_urdf_names_the_file(tmp_path, text, match):
    d = tmp_path / "Bottle" / "9"
    d.mkdir(parents=True)
    (d / "mobility.urdf").write_text(text)
    with pytest.raises(MomaError, match=match) as err:
        load_folder(tmp_path)
    assert str(d / "mobility.urdf") in str(err.value)


def test_missing_folder_is_a_moma_error(tmp_path):
    with pytest.raises(MomaError, match="does not exist"):
        scan_folder(tmp_path / "nowhere")


def test_unknown_category_for_sampling(tmp_path):
    with pytest.raises(MomaError, match="no external asset"):
        sample_external(scan_folder(_folder(tmp_path)), "fridge", np.random.default_rng(0))


@pytest.fixture
def registered_folder(tmp_path):
    register_external_assets(_folder(tmp_path), share=0.5)
    yield tmp_path
    clear_external_assets()


def test_registered_folder_feeds_the_categories(registered_folder, client):
    cat = get_category("cabinet")
    rng = np.random.default_rng(3)
    drawn = [cat.sample(rng, Envelope(0.6, 0.6, 0.9)) for _ in range(40)]
    external = [p for p in drawn if isinstance(p, ExternalParams)]
    assert 8 <= len(external) <= 32  # about half
    for p in (external[0], next(p for p in drawn if not isinstance(p, ExternalParams))):
        data = json.loads(json.dumps(dataclasses.asdict(p)))
        assert cat.params_from_dict(data) == p
        model = cat.build(p)
        assert max(np.asarray(model.size) - (0.6, 0.6, 0.9)) <= 1e-6
        load(model, client, fixed=True)
    # objects are scaled to a size typical of their category, not PartNet's unit scale
    bottle = get_category("bottle")
    rng = np.random.default_rng(0)
    ext = next(p for p in (bottle.sample(rng) for _ in range(40)) if isinstance(p, ExternalParams))
    model = bottle.build(ext)
    # the target height, or less where the bottle had to shrink to stay graspable
    assert 0.1 <= model.size[2] <= ext.target + 0.003
    assert max(model.size[:2]) <= 0.075
    assert model.grasps and max(g.width for g in model.grasps) <= 0.075


def test_procedural_streams_unchanged_without_registration(tmp_path):
    cat = get_category("cabinet")
    env = Envelope(0.6, 0.6, 0.9)
    before = [cat.sample(np.random.default_rng(5), env) for _ in range(3)]
    register_external_assets(_folder(tmp_path))
    clear_external_assets()
    after = [cat.sample(np.random.default_rng(5), env) for _ in range(3)]
    assert before == after
    # and categories without external assets never consume extra random numbers
    register_external_assets(tmp_path)
    try:
        fridge = get_category("fridge")
        env = Envelope(0.8, 0.7, 1.9)
        assert fridge.sample(np.random.default_rng(1), env) == fridge.sample_procedural(
            np.random.default_rng(1), env
        )
    finally:
        clear_external_assets()


def test_registering_a_broken_or_empty_folder_fails_naming_it(tmp_path):
    d = tmp_path / "broken" / "Refrigerator" / "3"
    d.mkdir(parents=True)
    (d / "mobility.urdf").write_text("<robot name='x'><link name='a'>")
    with pytest.raises(MomaError, match=r"Refrigerator/3/mobility\.urdf"):
        register_external_assets(tmp_path / "broken")
    (tmp_path / "empty" / "Spaceship" / "1").mkdir(parents=True)
    with pytest.raises(MomaError, match="no <category>"):
        register_external_assets(tmp_path / "empty")
