"""``momakitchen serve``: the model loaded once behind a small HTTP API.

A robot's own node sends each RGB-D frame to ``POST /predict`` (multipart form: depth as a
16-bit PNG in millimetres or .npy in metres, the target mask, optional colour and obstacle
masks, intrinsics ``fx fy cx cy``, ``camera_to_base`` as 16 numbers row-major, ``robot``
or ``reach`` and ``mount_height``, optional ``top_k`` and ``mc_samples``) and gets the
``prediction.json`` document back; ``GET /health`` answers with the model and version. The
default host, 127.0.0.1, serves this machine only: give --host 0.0.0.0 (or the address of
the robot's network) to serve a robot, on a network you trust (there is no
authentication). Needs the robot extra: pip install -e '.[robot]'. Stop with Ctrl-C.
"""

from __future__ import annotations

import argparse

from momakitchen.cli.common import add_robot_yaml, non_negative_int


def _port(text: str) -> int:
    value = non_negative_int(text)
    if value > 65535:
        raise argparse.ArgumentTypeError(f"expected a port in [0, 65535], got {text!r}")
    return value


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "serve", help="serve the model over HTTP for a robot's node", description=__doc__
    )
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=_port, default=8000, help="port (default 8000; 0: any free)")
    p.add_argument("--checkpoint", default=None, help="run directory (default: bundled model)")
    p.add_argument(
        "--mc-samples",
        type=non_negative_int,
        default=None,
        help="default MC-dropout passes of a request that does not say (predict's default: 8)",
    )
    add_robot_yaml(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.deploy.server import _require_aiohttp, serve
    from momakitchen.fileio import existing_dir

    _require_aiohttp()
    if args.checkpoint is not None:
        existing_dir(args.checkpoint, "checkpoint directory")

    def ready(host: str, port: int) -> None:
        print(
            f"serving on http://{host}:{port} (POST /predict, GET /health; Ctrl-C stops)",
            flush=True,
        )

    defaults = {} if args.mc_samples is None else {"mc_samples": args.mc_samples}
    try:
        serve(args.host, args.port, args.checkpoint, defaults, ready=ready)
    except KeyboardInterrupt:  # Ctrl-C is how a server stops: not an error
        print("stopped", flush=True)
    return 0
