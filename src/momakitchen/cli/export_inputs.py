"""``momakitchen export-inputs``: a split's model inputs in a plain file, for methods that
run outside momakitchen.

Writes, for every episode of the split that has floor points, its first-person cloud with
the target / obstacle channel, the floor points to score (in the order a predictions file
must follow), the robot descriptor and name, and the camera (intrinsics, camera-to-base
transform), under the key ``scene/config/episode`` of an ``.npz`` or ``.h5`` file that
NumPy or h5py read alone. Score the floor points, write a predictions file and pass it to
``evaluate``, ``msr`` or ``benchmark`` with ``--predictions`` (docs/METHODS.md).
"""

from __future__ import annotations

import argparse
import time

from momakitchen.cli.common import output_file
from momakitchen.fileio import existing_dir

SPLITS = ("test", "train", "all")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export-inputs",
        help="a split's model inputs as a plain .npz / .h5 (methods run elsewhere)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--data", required=True, help="dataset directory (momakitchen generate)")
    p.add_argument("--split", default="test", choices=SPLITS)
    p.add_argument("--out", required=True, help="the inputs file to write (.npz, .h5 or .hdf5)")
    p.add_argument(
        "--images", action="store_true", help="also each view's rgb and depth images (large)"
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.eval.predictions import export_inputs, file_kind

    root = existing_dir(args.data, "dataset directory")
    out = output_file(args.out)
    file_kind(out)  # a wrong suffix fails before any reading
    t0 = time.perf_counter()
    n = export_inputs(root, args.split, out, images=args.images)
    print(f"{n} {args.split} episodes in {time.perf_counter() - t0:.1f} s -> {out}")
    return 0
