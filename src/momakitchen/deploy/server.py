"""A model server: the model loaded once behind a small HTTP API, for a robot whose own node
sends its frames to a machine with the model.

``POST /predict`` takes a ``multipart/form-data`` body with the inputs of
:func:`momakitchen.predict`:

==================  ========  =========================================================
field               required  content
==================  ========  =========================================================
``depth``           yes       16-bit PNG (millimetres) or ``.npy`` (metres); 0 / NaN invalid
``target_mask``     yes       PNG or ``.npy``, non-zero = target
``intrinsics``      yes       ``fx fy cx cy`` (pixels; spaces or commas)
``camera_to_base``  yes       16 numbers, the 4x4 camera-to-base transform row-major
``robot``           one of    a registered robot name, or
``reach``,          these     the arm's reach and mount height (m)
``mount_height``
``rgb``             no        colour PNG / JPEG or ``.npy``
``obstacle_mask``   no        PNG or ``.npy``; repeat the field for several
``top_k``,          no        as in :func:`momakitchen.predict`
``mc_samples``,
``pick_radius``,
``min_spread``
``floor_points``    no        ``0`` leaves the floor points out of the answer (default 1)
==================  ========  =========================================================

The answer is the ``prediction.json`` document (:meth:`Prediction.to_dict`); the
``X-Predict-Seconds`` header says how long the model took. ``GET /health`` answers
``{"status", "model", "checkpoint", "version"}``. A bad request gets a 4xx status and a
one-line JSON ``{"error": ...}`` naming the bad field or value, never a traceback.

The server is `aiohttp` (asyncio): requests are read and answered concurrently while the
model runs on one worker thread, one frame at a time, so a prediction never shares torch
with another and ``/health`` answers while a frame is being predicted. Needs the ``robot``
extra.
"""

from __future__ import annotations

import asyncio
import io
import logging
import time
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

LOG = logging.getLogger("momakitchen.serve")
MAX_BODY_MB = 64  # a 640x480 float32 depth .npy is 1.2 MB; a 4K frame's fits too
REQUIRED = ("depth", "target_mask", "intrinsics", "camera_to_base")
FILES = ("depth", "target_mask", "rgb", "obstacle_mask")
NUMBERS = {"top_k": int, "mc_samples": int, "pick_radius": float, "min_spread": float}
TEXT = ("intrinsics", "camera_to_base", "robot", "reach", "mount_height", "floor_points")
FIELDS = (*FILES, *NUMBERS, *TEXT)


def _require_aiohttp() -> Any:
    try:
        from aiohttp import web
    except ImportError:
        raise MomaError("the server needs the robot extra: pip install -e '.[robot]'") from None
    return web


# ---------------------------------------------------------------------------- decoding
def decode_array(data: bytes, name: str) -> tuple[np.ndarray, str]:
    """An array and its format (``"npy"`` or ``"image"``) from an uploaded ``.npy``, PNG
    or JPEG file."""
    if data.startswith(b"\x93NUMPY"):
        try:
            return np.load(io.BytesIO(data), allow_pickle=False), "npy"
        except (ValueError, OSError, EOFError) as exc:
            raise MomaError(f"field {name!r} is not a readable .npy array ({exc})") from None
    if data.startswith((b"\x89PNG", b"\xff\xd8")):
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(io.BytesIO(data)) as img:
                return np.array(img), "image"
        except (UnidentifiedImageError, Image.DecompressionBombError, OSError, SyntaxError) as exc:
            raise MomaError(f"field {name!r} is not a readable image ({exc})") from None
    raise MomaError(f"field {name!r} must be a PNG, JPEG or .npy file")


def _numbers(text: str, name: str, count: int) -> list[float]:
    try:
        values = [float(v) for v in text.replace(",", " ").split()]
    except ValueError:
        raise MomaError(f"field {name!r} must be {count} numbers, got {text[:80]!r}") from None
    if len(values) != count or not np.isfinite(values).all():
        raise MomaError(f"field {name!r} must be {count} finite numbers, got {len(values)}")
    return values


def predict_arguments(
    files: Mapping[str, list[bytes]], text: Mapping[str, str]
) -> tuple[dict[str, Any], bool]:
    """The keyword arguments of :func:`momakitchen.predict` from a request's fields, and
    whether the answer includes the floor points. MomaError names a bad field."""
    from momakitchen.deploy.predict import load_depth

    unknown = sorted((set(files) | set(text)) - set(FIELDS))
    if unknown:
        raise MomaError(f"unknown field {unknown[0]!r}; the fields are {', '.join(FIELDS)}")
    for name in REQUIRED:
        if name not in files and name not in text:
            raise MomaError(f"missing field {name!r}")
    for name in files:
        if name not in FILES:
            raise MomaError(f"field {name!r} must be text, not a file")
    for name in FILES:
        if name in text:
            raise MomaError(f"field {name!r} must be a file upload")
        if name != "obstacle_mask" and len(files.get(name, [])) > 1:
            raise MomaError(f"field {name!r} is given more than once")

    depth, kind = decode_array(files["depth"][0], "depth")
    if kind == "image":
        if depth.dtype != np.uint16:
            raise MomaError(f"depth PNG must be 16-bit (millimetres), got {depth.dtype}")
        depth = depth.astype(np.float32) / 1000.0
    kwargs: dict[str, Any] = {
        "depth": load_depth(depth),
        "intrinsics": _numbers(text["intrinsics"], "intrinsics", 4),
        "camera_to_base": np.reshape(
            _numbers(text["camera_to_base"], "camera_to_base", 16), (4, 4)
        ),
        "target_mask": decode_array(files["target_mask"][0], "target_mask")[0],
        "obstacle_masks": [
            decode_array(b, f"obstacle_mask {i}")[0]
            for i, b in enumerate(files.get("obstacle_mask", []))
        ],
    }
    if "rgb" in files:
        kwargs["rgb"] = decode_array(files["rgb"][0], "rgb")[0]
    if "robot" in text:
        if "reach" in text or "mount_height" in text:
            raise MomaError("give either 'robot' or 'reach' and 'mount_height', not both")
        kwargs["robot"] = text["robot"]
    elif "reach" in text and "mount_height" in text:
        kwargs["robot"] = {
            "reach": _numbers(text["reach"], "reach", 1)[0],
            "mount_height": _numbers(text["mount_height"], "mount_height", 1)[0],
        }
    else:
        raise MomaError("missing field 'robot' (or both 'reach' and 'mount_height')")
    for name, kind_ in NUMBERS.items():
        if name in text:
            try:
                kwargs[name] = kind_(text[name])
            except ValueError:
                raise MomaError(
                    f"field {name!r} must be {'an integer' if kind_ is int else 'a number'}, "
                    f"got {text[name][:40]!r}"
                ) from None
    floor = text.get("floor_points", "1")
    if floor not in ("0", "1"):
        raise MomaError(f"field 'floor_points' must be 0 or 1, got {floor[:40]!r}")
    return kwargs, floor == "1"


# ---------------------------------------------------------------------------- the app
class ModelServer:
    """The loaded model and the one worker thread that runs it.

    ``predict_defaults`` go to every :func:`momakitchen.predict` call (a request's own
    fields override them).
    """

    def __init__(self, run: Any, predict_defaults: Mapping[str, Any] | None = None) -> None:
        self.run = run
        self.defaults = dict(predict_defaults or {})
        self.pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="momakitchen-model")

    def health(self) -> dict[str, Any]:
        from momakitchen.version import __version__

        return {
            "status": "ok",
            "model": self.run.config.model,
            "checkpoint": str(self.run.run_dir),
            "version": __version__,
        }

    def predict(
        self, files: Mapping[str, list[bytes]], text: Mapping[str, str]
    ) -> tuple[dict, float]:
        """The prediction.json document of one request and the model's seconds."""
        from momakitchen.deploy.predict import predict

        kwargs, floor = predict_arguments(files, text)
        t0 = time.perf_counter()
        pred = predict(**{**self.defaults, **kwargs}, checkpoint=self.run)
        return pred.to_dict(floor_points=floor), time.perf_counter() - t0

    def app(self) -> Any:
        """The aiohttp application."""
        web = _require_aiohttp()

        def error(status: int, message: str) -> Any:
            return web.json_response({"error": " ".join(message.split())}, status=status)

        async def health(_: Any) -> Any:
            return web.json_response(self.health())

        async def predict(request: Any) -> Any:
            if not request.content_type.startswith("multipart/"):
                return error(415, "send the frame as multipart/form-data")
            files: dict[str, list[bytes]] = {}
            text: dict[str, str] = {}
            try:
                form = await request.post()
            except web.HTTPRequestEntityTooLarge:
                return error(413, f"the request is larger than {MAX_BODY_MB} MB")
            except (ValueError, AssertionError, RuntimeError) as exc:
                return error(400, f"malformed multipart body: {exc}")
            for name, value in form.items():
                if isinstance(value, web.FileField):
                    files.setdefault(name, []).append(value.file.read())
                elif name in text:
                    return error(400, f"field {name!r} is given more than once")
                else:
                    text[name] = str(value)
            loop = asyncio.get_running_loop()
            try:
                doc, seconds = await loop.run_in_executor(self.pool, self.predict, files, text)
            except MomaError as exc:
                return error(400, str(exc))
            except Exception as exc:  # a bug, not the client's fault: log it, answer one line
                LOG.exception("prediction failed")
                return error(500, f"internal error: {type(exc).__name__}: {exc}")
            return web.json_response(doc, headers={"X-Predict-Seconds": f"{seconds:.4f}"})

        app = web.Application(client_max_size=MAX_BODY_MB * 1024 * 1024)
        app.router.add_get("/health", health)
        app.router.add_post("/predict", predict)

        async def close(_: Any) -> None:
            self.pool.shutdown(wait=False, cancel_futures=True)

        app.on_cleanup.append(close)
        return app


def serve(
    host: str = "127.0.0.1",
    port: int = 8000,
    checkpoint: Any = None,
    predict_defaults: Mapping[str, Any] | None = None,
    ready: Any = None,
) -> None:
    """Load the model and serve until interrupted. ``ready(host, port)`` is called once
    the socket listens."""
    from momakitchen.train.checkpoint import LoadedRun, default_checkpoint, load_checkpoint

    web = _require_aiohttp()
    run = (
        checkpoint
        if isinstance(checkpoint, LoadedRun)
        else load_checkpoint(checkpoint if checkpoint is not None else default_checkpoint())
    )
    server = ModelServer(run, predict_defaults)

    async def main() -> None:
        runner = web.AppRunner(server.app(), access_log=None)
        await runner.setup()
        site = web.TCPSite(runner, host, port)
        try:
            await site.start()
        except OSError as exc:
            await runner.cleanup()
            raise MomaError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
        try:
            if ready is not None:
                bound = runner.addresses[0][1] if runner.addresses else port
                ready(host, bound)
            await asyncio.Event().wait()  # until cancelled (Ctrl-C)
        finally:
            await runner.cleanup()

    asyncio.run(main())
