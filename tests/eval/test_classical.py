"""Classical base placement (ring, reachability) as methods of the tracks: msr scores their
maps at the judged view's floor points, the approach track drives them as it drives a
model, and a map without spread looks under ``uncertain`` as ``relook`` does."""

from __future__ import annotations

import pytest

from momakitchen.errors import MomaError
from momakitchen.eval.approach.config import ApproachConfig
from momakitchen.eval.approach.track import run_approach
from momakitchen.eval.msr import MsrConfig, run_msr


@pytest.mark.slow  # the reachability maps of the fixture's robots are sampled first
def test_msr_scores_the_classical_methods_on_the_judged_views(real_dataset):
    result = run_msr(real_dataset, methods=["ring", "reachability", "oracle"], config=MsrConfig())
    assert list(result["methods"]) == ["ring", "reachability", "oracle"]
    for record in result["records"]:
        for name in ("ring", "reachability"):
            got = record["methods"][name]
            assert got["points"] and len(got["outcomes"]) == len(got["points"])
            assert all(0.0 <= a <= 1.0 for a in got["affordance"])  # a map, as a model's
    again = run_msr(real_dataset, methods=["ring", "reachability", "oracle"], config=MsrConfig())
    assert again["records"] == result["records"]
    with pytest.raises(MomaError, match="unknown MSR method 'circle'"):
        run_msr(real_dataset, methods=["circle"])


def test_msr_counts_a_view_the_classical_method_cannot_read_as_its_failure(
    real_dataset, monkeypatch
):
    # A view with too little floor to fit a plane is the method's failure there, recorded
    # with its cause; the run goes on. A fatal error (a broken method) still stops it.
    import momakitchen.placement.methods as methods

    def no_floor(*_, **__):
        raise MomaError("no floor plane found: 481 supporting points", cause="no_floor")

    monkeypatch.setattr(methods, "place_frame", no_floor)
    result = run_msr(real_dataset, methods=["ring", "oracle"], config=MsrConfig(max_configs=1))
    ring = result["records"][0]["methods"]["ring"]
    assert ring == {"points": [], "outcomes": [], "stages": [], "cause": "no_floor"}
    assert result["methods"]["ring"]["top1"] == 0.0
    assert result["records"][0]["methods"]["oracle"]["points"]

    def broken(*_, **__):
        error = MomaError("the method is broken")
        error.fatal = True
        raise error

    monkeypatch.setattr(methods, "place_frame", broken)
    with pytest.raises(MomaError, match="the method is broken"):
        run_msr(real_dataset, methods=["ring"], config=MsrConfig(max_configs=1))


def test_the_approach_drives_a_classical_method_and_uncertain_looks_as_relook(real_dataset):
    cfg = ApproachConfig(policies=("relook", "uncertain"), max_configs=1)
    result = run_approach(real_dataset, baselines=["ring"], config=cfg)
    relook, uncertain = (
        [r for r in result["records"] if r["policy"] == p] for p in ("relook", "uncertain")
    )
    assert relook and len(relook) == len(uncertain)
    for a, b in zip(relook, uncertain, strict=True):
        assert a["method"] == b["method"] == "ring"
        assert a["looks"][0]["cause"] != "costmap"  # its own look, a map
        same = ("path", "goal", "final", "success", "stage")
        assert {k: a[k] for k in same} == {k: b[k] for k in same}
        untimed = [
            [{k: v for k, v in look.items() if k != "seconds"} for look in r["looks"]]
            for r in (a, b)
        ]
        assert untimed[0] == untimed[1]


def test_the_robustness_track_scores_a_classical_method_under_corruptions(real_dataset):
    from momakitchen.eval.robustness.track import run_robustness
    from momakitchen.eval.robustness.views import RobustnessConfig

    config = RobustnessConfig(corruptions=("clean", "kinect"), max_configs=1)
    result = run_robustness(real_dataset, methods=["ring"], config=config)
    assert list(result["models"]) == ["ring"]  # no model loaded when none is asked for
    (record,) = result["records"]
    for view in record["views"]["ring"].values():
        assert view["status"] == "ok" and len(view["outcomes"]) == 1  # tried in physics
        assert -1.0 <= view["pcc"] <= 1.0
    with pytest.raises(MomaError, match="unknown method 'circle'"):
        run_robustness(real_dataset, methods=["circle"], config=config)


def test_a_classical_look_fuses_only_its_positive_cells(monkeypatch):
    """A zero of a classical map says "not a stance": a look whose map is zero everywhere
    gives the fusion no goal, rather than an arbitrary zero cell."""
    from types import SimpleNamespace

    import numpy as np

    import momakitchen.placement.methods as methods
    from momakitchen.deploy.fusion import MapFusion
    from momakitchen.eval.approach.episode import ClassicalPerceiver
    from momakitchen.models.inference import Prediction

    def fake_place(name, *args, **kwargs):
        xyz = np.array([[1.0, 0.0, 0.0], [1.5, 0.0, 0.0], [2.0, 0.0, 0.0]])
        aff = np.array(values)
        zeros = np.zeros(3)
        return Prediction(xyz, aff, zeros, xyz[:1], aff[:1], zeros[:1], np.zeros(3), "p", name)

    monkeypatch.setattr(methods, "place", fake_place)
    frame = SimpleNamespace(depth=None, intrinsics=None, camera_to_base=None, target_mask=None)
    frame.obstacle_masks = ()
    values = [0.0, 0.4, 0.0]
    pred = ClassicalPerceiver("ring")(frame, "panda", True, ApproachConfig())
    assert pred.floor_xyz.tolist() == [[1.5, 0.0, 0.0]] and pred.affordance.tolist() == [0.4]
    values = [0.0, 0.0, 0.0]
    fusion = MapFusion()
    fusion.add(ClassicalPerceiver("ring")(frame, "panda", True, ApproachConfig()), (0, 0, 0))
    assert fusion.looks == 1 and fusion.goal() is None
