"""Benchmark the learning models: parameters, training samples/s, inference ms per episode.

Usage::

    python benchmarks/bench_models.py                      # cpu and paper presets, all models
    python benchmarks/bench_models.py --presets cpu --threads 1 2 --out docs/bench/learning.md

Episodes are synthetic (:mod:`momakitchen.data.synthetic`) with exactly the preset's point
counts. Inference: one episode per forward pass (the on-robot case), eval mode, median of
``--repeats`` runs after two warm-up runs. Training: forward + backward + optimiser step
(the preset's) on a pre-collated batch (weighted MSE), median over ``--train-steps``
steps after one warm-up.
The 1-minute load average before and after each row is recorded: these machines are shared,
and other processes inflate the timings.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

# Sleep rather than spin in idle OpenMP threads: on a shared machine spinning threads fight
# other processes for the cores (measured here: 142 ms vs 54 ms for the same forward pass).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import torch

from momakitchen.data.batch import collate_episodes
from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes
from momakitchen.models import build_model, model_names, num_parameters
from momakitchen.train import preset_config

TRAIN_BATCH = {"cpu": 16, "paper": 4}


def _median_time(fn, repeats: int, warmup: int) -> float:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def bench_one(preset: str, name: str, threads: int, repeats: int, train_steps: int) -> dict:
    torch.set_num_threads(threads)
    cfg = preset_config(preset, name)
    batch_size = TRAIN_BATCH[preset]
    data = SyntheticEpisodes(
        SyntheticConfig(
            num_episodes=batch_size,
            num_global=cfg.num_global,
            num_floor=cfg.num_floor,
            min_fill=1.0,
            seed=11,
        )
    )
    samples = [data[i] for i in range(batch_size)]
    one = collate_episodes(samples[:1], cfg.num_global, cfg.num_floor)
    one.pop("floor_label")
    batch = collate_episodes(samples, cfg.num_global, cfg.num_floor)
    torch.manual_seed(0)
    model = build_model(name, cfg.model_config)
    load0 = os.getloadavg()[0]

    model.eval()

    def infer():
        with torch.inference_mode():
            model(one)

    infer_s = _median_time(infer, repeats, warmup=2)

    model.train()
    opt_class = torch.optim.AdamW if cfg.decoupled_weight_decay else torch.optim.Adam
    opt = opt_class(model.parameters(), lr=cfg.lr, betas=cfg.betas, weight_decay=cfg.weight_decay)

    def step():
        out = model(batch)
        opt.zero_grad(set_to_none=True)
        out["loss"].backward()
        opt.step()

    step_s = _median_time(step, train_steps, warmup=1)
    return {
        "preset": preset,
        "model": name,
        "threads": threads,
        "params": num_parameters(model),
        "infer_ms": infer_s * 1e3,
        "train_batch": batch_size,
        "train_sps": batch_size / step_s,
        "load": (load0, os.getloadavg()[0]),
        "points": (cfg.num_global, cfg.num_floor),
    }


BEGIN, END = "<!-- bench_models:begin -->", "<!-- bench_models:end -->"


def to_markdown(rows: list[dict], command: str, started: str) -> str:
    lines = [
        f"Produced by `{command}` (started {started}).",
        "",
        f"Machine: {platform.machine()}, {os.cpu_count()} CPU cores, Python "
        f"{platform.python_version()}, torch {torch.__version__} (CPU), "
        f"OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY', '')}. Synthetic episodes "
        "with exactly the preset's point counts.",
        "",
        "- **inference ms**: one episode per forward pass (what a robot calls), eval mode,",
        "  median of repeated runs after warm-up; includes sampling and grouping.",
        "- **train samples/s**: forward + backward + Adam step on a collated batch (batch "
        f"{TRAIN_BATCH['cpu']} for `cpu`, {TRAIN_BATCH['paper']} for `paper`; the `paper` "
        "recipe trains with 64), median over steps.",
        "- **load**: 1-minute load average before / after the row. The machine is shared; a",
        "  load above the core count means other processes competed for the cores and the",
        "  timings of that row are pessimistic.",
        "",
        "| preset | model | threads | points (global / floor) | parameters | inference ms / "
        "episode | train samples/s | load |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['preset']} | {r['model']} | {r['threads']} | {r['points'][0]} / "
            f"{r['points'][1]} | {r['params']:,} | {r['infer_ms']:.1f} | "
            f"{r['train_sps']:.2f} | {r['load'][0]:.1f} / {r['load'][1]:.1f} |"
        )
    return "\n".join(lines) + "\n"


def write_report(path: Path, body: str) -> None:
    """Replace the generated section of ``path`` (between the markers), keeping the rest."""
    block = f"{BEGIN}\n{body}{END}\n"
    text = path.read_text() if path.is_file() else ""
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        tail = rest.split(END, 1)[1].lstrip("\n")
        text = head + block + ("\n" + tail if tail else "")
    else:
        text = "# Learning benchmark: model sizes, training and inference speed\n\n" + block
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", nargs="+", default=["cpu", "paper"])
    parser.add_argument("--models", nargs="+", default=list(model_names()))
    parser.add_argument("--threads", nargs="+", type=int, default=[2])
    parser.add_argument("--repeats", type=int, default=9, help="inference runs per row")
    parser.add_argument("--train-steps", type=int, default=3, help="timed training steps")
    parser.add_argument("--paper-repeats", type=int, default=3)
    parser.add_argument("--out", default=None, help="write a Markdown table here")
    args = parser.parse_args(argv)
    started = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    rows = []
    for preset in args.presets:
        for threads in args.threads:
            for name in args.models:
                repeats = args.repeats if preset == "cpu" else args.paper_repeats
                steps = args.train_steps if preset == "cpu" else min(args.train_steps, 2)
                r = bench_one(preset, name, threads, repeats, steps)
                rows.append(r)
                print(
                    f"{preset:6s} {name:18s} threads {threads} params {r['params']:>10,} "
                    f"infer {r['infer_ms']:8.1f} ms  train {r['train_sps']:7.2f} samples/s  "
                    f"load {r['load'][0]:.1f}/{r['load'][1]:.1f}",
                    flush=True,
                )
    if args.out:
        command = "python benchmarks/bench_models.py " + " ".join(
            a if " " not in a else repr(a) for a in (argv if argv is not None else sys.argv[1:])
        )
        write_report(Path(args.out), to_markdown(rows, command.strip(), started))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
