"""Does a NavAff run use the global cloud? Every test view scored as usual and once with the
global tokens hidden from the cross-attention (key padding: only the robot tokens left).

    python analyses/global_tokens.py --data ~/mk-data/gt2-300 --every 60 \
        --checkpoint src/momakitchen/checkpoints/navaff results/runs/lambda-0.7

Per run, over the views with a successful position: the attention mass the floor tokens
put on the robot tokens (mean over heads, tokens and layers), the map's PCC with the label,
and the label at the map's best point (MSR's Top-1 pick), as scored and with the global
tokens hidden. A run that drew its maps from the floor, the target offset and the robot
alone scores the same either way.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
import torch
from analysis_cli import add_view_args, run_main, test_views
from torch.utils.data import Subset

from momakitchen.data.batch import episode_maps
from momakitchen.errors import MomaError
from momakitchen.eval.evaluate import predicted_maps
from momakitchen.metrics import episode_metrics
from momakitchen.models.inference import predict_batch
from momakitchen.train.checkpoint import load_checkpoint


def global_token_use(run_dir: Path, data: Subset) -> dict[str, float]:
    """Means over the views whose label has a success (keys: ``views``, ``robot_attention``,
    ``pcc``, ``pcc_hidden``, ``best``, ``best_hidden``)."""
    run = load_checkpoint(run_dir)
    backbone = run.model.backbone
    if not (getattr(backbone, "use_global", False) and getattr(backbone, "use_robot", False)):
        raise MomaError(f"{run_dir}: not a NavAff run with global and robot tokens")
    r = backbone.robot_tokenizer.num_tokens
    mass: list[float] = []

    def record(attn: torch.nn.Module, args: tuple, kwargs: dict[str, Any], out: Any) -> None:
        q, k, v = args
        pad = kwargs.get("key_padding_mask")
        _, w = type(attn).forward(attn, q, k, v, key_padding_mask=pad, need_weights=True)
        mass.append(float(w[..., -r:].sum(-1).mean()))  # the robot tokens come last

    encode = backbone.encode

    def encode_hidden(batch: dict[str, Any]) -> dict[str, torch.Tensor]:
        ctx = encode(batch)
        pad = ctx["kv_pad"].clone()
        pad[:, :-r] = True
        return {**ctx, "kv_pad": pad}

    rows = []
    for batch, preds, labels in predicted_maps(run, data):
        hooks = [b.attn.register_forward_hook(record, with_kwargs=True) for b in backbone.blocks]
        predict_batch(run.model, batch)  # once more, to record the attention
        for h in hooks:
            h.remove()
        backbone.encode = encode_hidden
        try:
            hidden, _ = episode_maps(batch, predict_batch(run.model, batch))
        finally:
            backbone.encode = encode
        for p, q, g in zip(preds, hidden, labels, strict=True):
            if (g > 0).any():
                rows.append(
                    (
                        episode_metrics(p, g)["pcc"],
                        episode_metrics(q, g)["pcc"],
                        float(g[np.argmax(p)]),
                        float(g[np.argmax(q)]),
                    )
                )
    if not rows:
        raise MomaError("no test view with a successful position among those scored")
    m = np.array(rows).mean(0)
    means = dict(zip(("pcc", "pcc_hidden", "best", "best_hidden"), m.tolist(), strict=True))
    return {"views": len(rows), "robot_attention": float(np.mean(mass)), **means}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_view_args(ap, every=60)
    args = ap.parse_args()
    subset = test_views(args)
    print(
        "| run | views | attention on the robot tokens | PCC | PCC, global tokens hidden | "
        "label at the best point | the same, hidden |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for run in args.checkpoint:
        u = global_token_use(run, subset)
        print(
            f"| {run.name} | {u['views']} | {u['robot_attention']:.2f} | {u['pcc']:.3f} | "
            f"{u['pcc_hidden']:.3f} | {u['best']:.3f} | {u['best_hidden']:.3f} |"
        )


if __name__ == "__main__":
    run_main(main, "global_tokens.py")
