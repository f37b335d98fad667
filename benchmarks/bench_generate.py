"""End-to-end throughput of ``momakitchen generate`` (docs/bench/dataset.md).

Runs the command ``--runs`` times into fresh directories and reports, per run and as the
median: episodes per CPU-second (user + system time of the command and its workers, what
a dedicated core delivers; with Ray, whose workers are not children of the command,
episodes per wall second per core instead), peak RSS of the largest process, bytes per
episode, and the extrapolated time for the paper's 127,343 episodes.

    python benchmarks/bench_generate.py --scenes 4 --workers 1 --runs 3
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PAPER_EPISODES = 127_343


def one_run(args: argparse.Namespace, out: Path) -> dict:
    cmd = [
        sys.executable,
        "-m",
        "momakitchen.cli.main",
        "generate",
        "--out",
        str(out),
        "--scenes",
        str(args.scenes),
        "--first-scene-id",
        str(args.first_scene_id),
        "--workers",
        str(args.workers),
        "--backend",
        args.backend,
        "--quiet",
    ]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    manifest = json.loads((out / "manifest.json").read_text())
    episodes = manifest["counts"]["total"]["episodes"]
    size = sum(f.stat().st_size for f in (out / "scenes").glob("*.h5"))
    seen = args.backend != "ray"  # Ray's workers are not children: their CPU time is unseen
    return {
        "episodes": episodes,
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1) if seen else None,
        "episodes_per_cpu_s": round(episodes / cpu, 3) if seen else None,
        "episodes_per_wall_s_per_core": round(episodes / wall / args.workers, 3),
        "peak_rss_mib": round(after.ru_maxrss / 1024),
        "bytes_per_episode": size // max(episodes, 1),
        "load_before": round(os.getloadavg()[0], 2),
    }


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--scenes", type=int, default=4)
    ap.add_argument("--first-scene-id", type=int, default=0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--backend", default="local")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", default=None, help="write the results here")
    args = ap.parse_args()
    runs = []
    for i in range(args.runs):
        out = Path(tempfile.mkdtemp(prefix="mk-bench-gen-"))
        shutil.rmtree(out)
        try:
            runs.append(one_run(args, out))
        finally:
            shutil.rmtree(out, ignore_errors=True)
        print(f"run {i + 1}: {runs[-1]}", flush=True)
    key = "episodes_per_wall_s_per_core" if args.backend == "ray" else "episodes_per_cpu_s"
    rate = statistics.median(r[key] for r in runs)
    summary = {
        "command": f"generate --scenes {args.scenes} --first-scene-id {args.first_scene_id} "
        f"--workers {args.workers} --backend {args.backend}",
        "runs": runs,
        f"median_{key}": rate,
        "paper_hours_1_core": round(PAPER_EPISODES / rate / 3600, 1),
        "paper_minutes_64_cores": round(PAPER_EPISODES / rate / 64 / 60, 1),
    }
    print(json.dumps({k: v for k, v in summary.items() if k != "runs"}, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps(summary, indent=1) + "\n")


if __name__ == "__main__":
    main()
