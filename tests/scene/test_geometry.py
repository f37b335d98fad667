import numpy as np
import pytest

from momakitchen.assets.urdf_frames import link_rest_poses, rpy_matrix
from momakitchen.scene.geometry import Footprint, overlaps, semicircle_grid


def test_overlap_axis_aligned_and_rotated():
    a = Footprint(0, 0, 0, 1.0, 1.0)
    assert overlaps(a, Footprint(0.9, 0, 0, 1.0, 1.0))
    assert not overlaps(a, Footprint(1.1, 0, 0, 1.0, 1.0))
    # A square rotated by 45 degrees reaches sqrt(0.5) from its centre.
    assert overlaps(a, Footprint(1.2, 0, np.pi / 4, 1.0, 1.0))
    assert not overlaps(a, Footprint(1.25, 0, np.pi / 4, 1.0, 1.0))


def test_corners_and_inflation():
    fp = Footprint(1, 2, np.pi / 2, 2.0, 1.0)
    c = fp.corners()
    assert c[:, 0].min() == pytest.approx(0.5) and c[:, 1].max() == pytest.approx(3.0)
    big = fp.inflated(0.1)
    assert big.length == pytest.approx(2.2) and big.width == pytest.approx(1.2)


def test_semicircle_grid_is_a_half_disc_on_a_shared_lattice():
    pts = semicircle_grid((1.03, 0.6), 0.85, 0.1)
    rel = pts - np.array([1.03, 0.6])
    assert np.all(np.linalg.norm(rel, axis=1) <= 0.85 + 1e-9)
    assert np.all(rel[:, 1] > 0)
    # Grid lines at multiples of the spacing, independent of the centre.
    assert np.allclose(np.round(pts / 0.1) * 0.1, pts)
    # About half the disc area divided by the cell area.
    assert abs(len(pts) - np.pi * 0.85**2 / 2 / 0.01) < 25


def test_rpy_matrix_matches_urdf_convention():
    # Fixed-axis rpy: roll about x first, then pitch about y, then yaw about z.
    r = rpy_matrix(np.pi / 2, 0, np.pi / 2)
    assert np.allclose(r @ [0, 1, 0], [0, 0, 1], atol=1e-12)
    assert np.allclose(r @ [1, 0, 0], [0, 1, 0], atol=1e-12)


def test_link_rest_poses_follow_the_chain():
    urdf = """<robot name="t"><link name="a"/><link name="b"/><link name="c"/>
    <joint name="j1" type="revolute"><parent link="a"/><child link="b"/>
      <origin xyz="1 0 0" rpy="0 0 1.5707963267948966"/></joint>
    <joint name="j2" type="fixed"><parent link="b"/><child link="c"/>
      <origin xyz="1 0 0"/></joint></robot>"""
    poses = link_rest_poses(urdf)
    assert np.allclose(poses["c"][:3, 3], [1, 1, 0], atol=1e-9)
