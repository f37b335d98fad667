"""``momakitchen serve``: the model loaded once behind a small HTTP API.

A robot's own node sends each RGB-D frame to ``POST /predict`` (multipart form: depth as a
16-bit PNG in millimetres or .npy in metres, the target mask, optional colour and obstacle
masks, intrinsics ``fx fy cx cy``, ``camera_to_base`` as 16 numbers row-major, ``robot``
or ``reach`` and ``mount_height``, optional ``top_k`` (1-50), ``mc_samples`` (0-64),
``pick_radius`` (0-1 m), ``min_spread`` (0-5 m) and ``floor_points`` (0 or 1)) and gets the
``prediction.json`` document back; ``GET /health`` answers with the model and version.

Limits: a body of at most --max-body-mb (413 beyond); at most --max-inflight-mb of bodies
being read, waiting or predicted at once and at most --queue requests waiting for the model
(503 with Retry-After beyond); --read-timeout seconds each to send a request's headers, its
body (408) and to take the answer, then the connection is closed; images of at most
4096x4096 (16 Mpx), checked from their headers before decoding; .npy files of numbers only
(finite ones for colour and masks); at most 64 form fields and 4096 bytes a text field (413);
no Content-Encoding (415). A client that has gone is not predicted; one frame of at most 64
MC-dropout passes that is running finishes first. Every refusal, a malformed HTTP request
included, is one line of JSON {"error": ...} naming the field.

The default host, 127.0.0.1, serves this machine only. To serve a robot, give --host
0.0.0.0 (or the address of the robot's network) and a token: --token, or better the
MOMAKITCHEN_SERVE_TOKEN environment variable (a command line is visible to every user of
the machine); every request must then carry "Authorization: Bearer <token>" (401
otherwise). Another address without a token is refused. Needs the robot extra: pip
install -e '.[robot]'. Stop with Ctrl-C.
"""

from __future__ import annotations

import argparse
import os

from momakitchen.cli.common import checked_run_dir, non_negative_int, positive_float, positive_int
from momakitchen.cli.options import MC_SAMPLES, add_checkpoint, add_robot_yaml
from momakitchen.errors import MomaError
from momakitchen.eval.methods import CLASSICAL

MAX_MC_SAMPLES = 64  # the server's own limit on a request's mc_samples


def _port(text: str) -> int:
    value = non_negative_int(text)
    if value > 65535:
        raise argparse.ArgumentTypeError(f"expected a port in [0, 65535], got {text!r}")
    return value


def _mc_samples(text: str) -> int:
    value = non_negative_int(text)
    if value > MAX_MC_SAMPLES:
        raise argparse.ArgumentTypeError(
            f"expected an integer in [0, {MAX_MC_SAMPLES}], got {text!r}"
        )
    return value


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "serve",
        help="serve the model over HTTP for a robot's node",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=_port, default=8000, help="port (default 8000; 0: any free)")
    add_checkpoint(p)
    p.add_argument(
        "--method",
        choices=CLASSICAL,
        default=None,
        help="serve a classical base-placement method instead of a model (docs/PLACEMENT.md)",
    )
    p.add_argument(
        "--mc-samples",
        type=_mc_samples,
        default=None,
        help="default MC-dropout passes of a request that does not say (predict's default: "
        f"{MC_SAMPLES}; at most {MAX_MC_SAMPLES})",
    )
    p.add_argument(
        "--token",
        default=None,
        help="the bearer token every request must carry (default: $MOMAKITCHEN_SERVE_TOKEN; "
        "needed on any address but a loopback one)",
    )
    p.add_argument(
        "--queue",
        type=non_negative_int,
        default=4,
        help="requests that may wait for the model behind the one it predicts (default 4); "
        "more get 503 with Retry-After",
    )
    p.add_argument(
        "--max-body-mb",
        type=positive_int,
        default=64,
        help="largest request body in MB (default 64); larger ones get 413",
    )
    p.add_argument(
        "--max-inflight-mb",
        type=positive_int,
        default=256,
        help="MB of request bodies being read, waiting or predicted at once (default 256); "
        "beyond, 503 with Retry-After",
    )
    p.add_argument(
        "--read-timeout",
        type=positive_float,
        default=30.0,
        help="seconds a client has to send a request's headers, its body (408) and to take "
        "the answer (default 30)",
    )
    add_robot_yaml(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from momakitchen.deploy.server import TOKEN_ENV, Limits, _require_aiohttp, serve

    _require_aiohttp()
    limits = Limits(args.queue, args.max_body_mb, args.max_inflight_mb, args.read_timeout)
    token = args.token if args.token is not None else (os.environ.get(TOKEN_ENV) or None)
    if args.checkpoint is not None:
        if args.method is not None:
            raise MomaError("give --checkpoint or --method, not both")
        checked_run_dir(args.checkpoint)

    def ready(host: str, port: int) -> None:
        guard = "; a token is required" if token else ""
        print(
            f"serving on http://{host}:{port} (POST /predict, GET /health; Ctrl-C stops){guard}",
            flush=True,
        )

    defaults = {} if args.mc_samples is None else {"mc_samples": args.mc_samples}
    try:
        serve(
            args.host,
            args.port,
            args.checkpoint,
            defaults,
            ready=ready,
            limits=limits,
            token=token,
            method=args.method,
        )
    except KeyboardInterrupt:  # Ctrl-C is how a server stops: not an error
        print("stopped", flush=True)
    return 0
