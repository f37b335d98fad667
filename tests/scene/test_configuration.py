"""Configurations that a competent robot can solve: obstacles leave the part's sweep and
the arm's way clear."""

from __future__ import annotations

import numpy as np

from momakitchen.scene.configuration import _corridors, part_sweep, sample_scene
from momakitchen.scene.geometry import box_corners, corners_of, overlap_matrix


def test_part_sweep_covers_the_handle_and_the_floor_in_front():
    checked = 0
    for sid in range(300, 306):
        scene = sample_scene(sid)
        for cfg in scene.configurations:
            t = cfg.target
            if t.articulation is None:
                continue
            sweep = part_sweep(scene.layout.unit(t.uid), t.articulation)[0]
            lo, hi = sweep.min(0), sweep.max(0)
            # The handle at rest lies inside, with the margin around it.
            assert np.all(lo + 0.099 <= t.anchor[:2]) and np.all(t.anchor[:2] <= hi - 0.099)
            # Opening moves the handle out of the furniture, towards the room (+y).
            assert hi[1] > t.anchor[1] + 0.1
            # No obstacle stands where the part swings or slides.
            obstacles = corners_of([o.footprint() for o in cfg.obstacles])
            assert not overlap_matrix(obstacles, sweep[None]).any()
            checked += 1
    assert checked >= 10


def test_corridors_run_from_each_base_to_the_target():
    anchor = np.array([1.0, 0.5, 0.9])
    bases = box_corners(np.array([1.0, 2.0]), np.array([1.3, 1.0]), 0.0, 0.5, 0.4)
    c = _corridors(bases, anchor)
    assert c.shape == (2, 4, 2)
    for k, centre in enumerate(bases.mean(1)):
        ends = c[k].mean(0)
        assert np.allclose(ends, (centre + anchor[:2]) / 2)
        length = np.linalg.norm(c[k][0] - c[k][1])
        assert np.isclose(length, np.linalg.norm(anchor[:2] - centre))
