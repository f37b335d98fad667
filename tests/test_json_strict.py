"""Every JSON document the project writes is strict JSON: NaN and infinity are refused with
one line naming their place (nothing written), or written as null where a missing value is
legitimate; and no writer in src/ can bypass that."""

from __future__ import annotations

import ast
import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch

from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict

SRC = Path(__file__).resolve().parents[1] / "src" / "momakitchen"


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, np.float64("nan")])
def test_dumps_strict_refuses_non_finite_numbers_naming_their_place(bad):
    doc = {"poses": [{"x": 1.0}, {"x": 2.0, "y": bad}], "ok": True}
    with pytest.raises(MomaError) as info:
        dumps_strict(doc, indent=1)
    message = str(info.value)
    assert "\n" not in message and "poses[1].y" in message and str(float(bad)) in message
    # numpy's own floats, which json writes through default=float
    with pytest.raises(MomaError, match=r"metrics\.mae is nan"):
        dumps_strict({"metrics": {"mae": np.float32("nan")}}, default=float)


def test_dumps_strict_writes_what_json_writes_or_null_when_asked():
    doc = {"a": [1, 2.5, None, "x"], "b": {"c": False}, "n": np.float32(0.5)}
    assert dumps_strict(doc, default=float) == json.dumps(doc, default=float)
    out = json.loads(dumps_strict({"r": [math.inf, 1.0, {"d": math.nan}]}, null_non_finite=True))
    assert out == {"r": [None, 1.0, {"d": None}]}
    loop: list = []
    loop.append(loop)
    with pytest.raises(ValueError, match="Circular reference"):  # json's own errors stay
        dumps_strict(loop)


def test_a_prediction_with_nan_is_not_written_over_the_previous_one(tmp_path):
    from momakitchen.deploy.predict import write_outputs
    from momakitchen.models.inference import Prediction

    def prediction(value: float) -> Prediction:
        return Prediction(
            floor_xyz=np.zeros((3, 3)),
            affordance=np.array([0.1, value, 0.3]),
            uncertainty=np.zeros(3),
            poses=np.zeros((1, 3)),
            pose_scores=np.array([value]),
            pose_uncertainty=np.zeros(1),
            target_xyz=np.array([1.0, 0.0, 0.5]),
            robot="panda",
            model="navaff",
        )

    write_outputs(prediction(0.5), tmp_path)
    before = (tmp_path / "prediction.json").read_bytes()
    with pytest.raises(MomaError, match=r"poses\[0\]\.affordance is nan"):
        write_outputs(prediction(math.nan), tmp_path)
    assert (tmp_path / "prediction.json").read_bytes() == before
    json.loads(before, parse_constant=lambda c: pytest.fail(f"{c} in prediction.json"))


def test_a_diverged_loss_is_saved_as_null_and_resumed_as_nan(tmp_path):
    from momakitchen.train.checkpoint import STATE_JSON, load_trainer_state, save_trainer_state

    param = torch.nn.Parameter(torch.zeros(2))
    optimizer = torch.optim.AdamW([param], lr=1e-3)
    param.grad = torch.ones(2)
    optimizer.step()
    history = [{"epoch": 1, "loss": math.nan}]
    progress = {"epoch": 1, "global_step": 3, "history": history}
    save_trainer_state(tmp_path, optimizer, {**progress, "epoch_loss_sum": [math.nan, 1.0, 4]})
    text = (tmp_path / STATE_JSON).read_text()
    body = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in {STATE_JSON}"))
    assert body["progress"]["history"][0]["loss"] is None
    back = load_trainer_state(tmp_path, torch.optim.AdamW([param], lr=1e-3))
    assert math.isnan(back["epoch_loss_sum"][0]) and back["epoch_loss_sum"][1:] == [1.0, 4]


def _writes_json(node: ast.Call) -> str | None:
    """``json.dumps`` / ``json.dump`` / ``json_response`` as named in the call, if it is one."""
    func = node.func
    if isinstance(func, ast.Attribute):
        if isinstance(func.value, ast.Name) and func.value.id == "json":
            return f"json.{func.attr}" if func.attr in ("dumps", "dump") else None
        return func.attr if func.attr == "json_response" else None
    return None


def test_no_writer_in_src_bypasses_strict_json():
    """A json.dumps / json.dump in src/ passes allow_nan=False (or is read straight back
    by json.loads); an aiohttp json_response passes a strict ``dumps``."""
    loose = []
    for path in sorted(SRC.rglob("*.py")):
        if path.name == "fileio.py":  # dumps_strict itself
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call) or (name := _writes_json(node)) is None:
                continue
            keywords = {k.arg: k.value for k in node.keywords}
            if name == "json_response":
                strict = "dumps" in keywords
            else:
                allow = keywords.get("allow_nan")
                strict = isinstance(allow, ast.Constant) and allow.value is False
                parent = parents.get(node)
                if (
                    isinstance(parent, ast.Call)
                    and isinstance(parent.func, ast.Attribute)
                    and parent.func.attr == "loads"
                ):
                    strict = True  # a round trip in memory, nothing written
            if not strict:
                loose.append(f"{path.relative_to(SRC)}:{node.lineno} {name}")
    assert not loose, "JSON written without allow_nan=False (use fileio.dumps_strict): " + str(
        loose
    )


def test_a_json_object_reads_the_same_gzipped_and_a_broken_one_names_its_file(tmp_path):
    import gzip

    from momakitchen.fileio import read_json_object

    obj = {"records": [{"success": 1}], "x": 0.5}
    plain, packed = tmp_path / "a.json", tmp_path / "a.json.gz"
    plain.write_text(json.dumps(obj))
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    assert read_json_object(plain) == read_json_object(packed) == obj
    packed.write_bytes(gzip.compress(plain.read_bytes())[:20])  # cut short
    with pytest.raises(MomaError, match=r"a\.json\.gz: cannot read JSON"):
        read_json_object(packed)
