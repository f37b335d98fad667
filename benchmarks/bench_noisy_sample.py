"""Benchmark the noise-aware training sample: CPU time of one sample rebuilt through a
random sensor (``EpisodeDataset`` with ``use_sensor_noise``: read the frame, corrupt it,
rebuild its clouds), with and without :func:`momakitchen.perception.clouds.reuse_freed_memory`.

Usage::

    python benchmarks/bench_noisy_sample.py --data DIR --samples 40 --rounds 3

Each round runs the same ``--samples`` random training episodes in two fresh processes, the
allocator left as it is and then set, and reports their CPU time (user + system, which
unlike wall time hardly depends on what else runs on the cores), system time and minor
page faults per sample, and whether both gave the same bytes. Prints one Markdown row of
the medians over ``--rounds``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

CHILD = """
import hashlib, json, resource, sys
import numpy as np
from momakitchen.data.torch_dataset import EpisodeDataset
from momakitchen.perception.clouds import reuse_freed_memory
from momakitchen.perception.sensors import SensorAugmentation
data, n, seed, tuned = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4] == "1"
applied = reuse_freed_memory() if tuned else False
ds = EpisodeDataset(data, split="train")
ds.use_sensor_noise(SensorAugmentation())
ds.set_epoch(1)
idx = np.random.default_rng(seed).choice(len(ds), n + 1, replace=False)
ds[int(idx[0])]  # shard handles and imports
digest = hashlib.sha256()
r0 = resource.getrusage(resource.RUSAGE_SELF)
for i in idx[1:]:
    sample = ds[int(i)]
    for key in sorted(sample):
        v = sample[key]
        digest.update(v.numpy().tobytes() if hasattr(v, "numpy") else repr(v).encode())
r1 = resource.getrusage(resource.RUSAGE_SELF)
user, system = r1.ru_utime - r0.ru_utime, r1.ru_stime - r0.ru_stime
print(json.dumps({"applied": applied, "cpu_ms": (user + system) / n * 1e3,
                  "sys_ms": system / n * 1e3, "faults": (r1.ru_minflt - r0.ru_minflt) / n,
                  "sha256": digest.hexdigest()}))
"""


def _child(data: str, samples: int, seed: int, tuned: bool) -> dict:
    # MALLOC_* variables would make reuse_freed_memory leave the allocator alone.
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    out = subprocess.run(
        [sys.executable, "-c", CHILD, data, str(samples), str(seed), "1" if tuned else "0"],
        check=True,
        capture_output=True,
        text=True,
        env=env,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="dataset directory (momakitchen generate)")
    ap.add_argument("--samples", type=int, default=40, help="samples per process")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    from momakitchen.data.torch_dataset import EpisodeDataset
    from momakitchen.errors import MomaError

    try:  # bad input fails here in one line, not in a child's traceback
        if len(EpisodeDataset(args.data, split="train")) <= args.samples:
            raise MomaError(f"{args.data}: fewer train episodes than --samples {args.samples}")
    except MomaError as exc:
        print(f"bench_noisy_sample.py: error: {exc}", file=sys.stderr)
        return 2
    rows: dict[bool, list[dict]] = {False: [], True: []}
    for r in range(args.rounds):
        for tuned in (False, True):
            res = _child(args.data, args.samples, r, tuned)
            rows[tuned].append(res)
            print(f"round {r} {'set' if tuned else 'default'}: {json.dumps(res)}", file=sys.stderr)
    same = all(a["sha256"] == b["sha256"] for a, b in zip(rows[False], rows[True], strict=True))
    load = os.getloadavg()[0]

    def med(tuned: bool, key: str) -> float:
        return statistics.median(x[key] for x in rows[tuned])

    ratio = med(True, "cpu_ms") / med(False, "cpu_ms")
    print(
        f"| a noisy training sample, {args.samples} samples × {args.rounds} rounds "
        f"(load {load:.1f}) | CPU {med(False, 'cpu_ms'):.0f} → {med(True, 'cpu_ms'):.0f} ms "
        f"(system {med(False, 'sys_ms'):.1f} → {med(True, 'sys_ms'):.1f} ms, page faults "
        f"{med(False, 'faults'):.0f} → {med(True, 'faults'):.0f}); same bytes: {same} "
        f"| {ratio:.2f} × |"
    )
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
