"""Benchmark of the procedural asset library.

    python -m momakitchen.assets.bench --samples 1000 --load 50

For every category: how many distinct instances ``--samples`` draws give (distinct URDF
text), how many discrete variants they cover (distinct combinations of the string and
integer parameters: style, layout, handle type, number of doors...), the mean sample and
build time, and the mean time to write the URDF to the cache
and load it in a PyBullet DIRECT client (over ``--load`` instances). Prints a Markdown table.
Envelopes vary like those a layout grants (see ``default_envelope``).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import tempfile
import time

import numpy as np

from momakitchen.assets import CATEGORIES, AssetModel, Envelope, get_category
from momakitchen.assets.cache import cached_urdf


def default_envelope(name: str, rng: np.random.Generator) -> Envelope | None:
    """An envelope in the ranges a kitchen layout uses (None for objects and obstacles)."""
    kind = get_category(name).kind
    if kind == "appliance":
        return Envelope(
            round(float(rng.uniform(0.45, 0.6)), 4), round(float(rng.uniform(0.33, 0.42)), 4), 0.4
        )
    if kind != "furniture":
        return None
    if name == "fridge":
        return Envelope(
            round(float(rng.uniform(0.7, 0.9)), 4),
            round(float(rng.uniform(0.6, 0.78)), 4),
            round(float(rng.uniform(1.75, 2.0)), 4),
        )
    lo, hi = {
        "cabinet": (0.45, 0.9),
        "sink": (0.6, 0.9),
        "dishwasher": (0.58, 0.62),
        "oven": (0.58, 0.76),
    }[name]
    return Envelope(
        round(float(rng.uniform(lo, hi)), 4),
        round(float(rng.uniform(0.56, 0.66)), 4),
        round(float(rng.uniform(0.86, 0.94)), 4),
    )


def run(samples: int, load: int, seed: int = 0) -> list[dict]:
    from momakitchen.bullet import p as pb

    rows = []
    client = pb.connect(pb.DIRECT)
    try:
        for name in sorted(CATEGORIES):
            cat = get_category(name)
            rng = np.random.default_rng(seed)
            texts = set()
            variants = set()
            t_sample = t_build = 0.0
            models: list[AssetModel] = []
            for _ in range(samples):
                t0 = time.perf_counter()
                params = cat.sample(rng, default_envelope(name, rng))
                t1 = time.perf_counter()
                model = cat.build(params)
                t2 = time.perf_counter()
                t_sample += t1 - t0
                t_build += t2 - t1
                texts.add(model.urdf)
                variants.add(
                    tuple(
                        v
                        for v in dataclasses.astuple(params)
                        if isinstance(v, (str, int)) and not isinstance(v, bool)
                    )
                )
                if len(models) < load:
                    models.append(model)
            loads = []
            for model in models:
                t0 = time.perf_counter()
                path = cached_urdf(model.urdf, name)
                body = pb.loadURDF(
                    str(path),
                    useFixedBase=True,
                    flags=pb.URDF_USE_INERTIA_FROM_FILE,
                    physicsClientId=client,
                )
                loads.append(time.perf_counter() - t0)
                pb.removeBody(body, physicsClientId=client)
            rows.append(
                {
                    "category": name,
                    "kind": cat.kind,
                    "samples": samples,
                    "distinct": len(texts),
                    "variants": len(variants),
                    "sample_ms": 1e3 * t_sample / samples,
                    "build_ms": 1e3 * t_build / samples,
                    "load_ms": 1e3 * statistics.mean(loads) if loads else float("nan"),
                    "links": max(m.urdf.count("<link ") for m in models) if models else 0,
                }
            )
    finally:
        pb.disconnect(client)
    return rows


def markdown(rows: list[dict]) -> str:
    out = [
        "| category | kind | distinct / samples | variants | sample (ms) | build (ms) | "
        "write + load (ms) | links (max) |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        out.append(
            f"| {r['category']} | {r['kind']} | {r['distinct']} / {r['samples']} | "
            f"{r['variants']} | "
            f"{r['sample_ms']:.2f} | {r['build_ms']:.2f} | {r['load_ms']:.2f} | "
            f"{r['links']} |"
        )
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--load", type=int, default=50, help="instances loaded in PyBullet")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    import os

    # a fresh cache: loading times then include writing the file, as on a first run
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["MOMAKITCHEN_CACHE"] = tmp
        print(markdown(run(args.samples, args.load, args.seed)))


if __name__ == "__main__":
    main()
