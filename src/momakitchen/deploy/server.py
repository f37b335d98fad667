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
``obstacle_mask``   no        PNG or ``.npy``; repeat the field for several (at most 16)
``top_k``           no        number of poses, an integer in [1, 50] (default 5)
``mc_samples``      no        MC-dropout passes, an integer in [0, 64] (default 8)
``pick_radius``     no        metres in [0, 1] (default 0), as in :func:`momakitchen.predict`
``min_spread``      no        metres in [0, 5] between poses (default 0.2)
``floor_points``    no        ``0`` leaves the floor points out of the answer (default 1)
``opens``           no        ``1``: the robot opens the target (a handle), ``0`` picks it
                              (default 0), as ``opens`` of :func:`momakitchen.predict`
==================  ========  =========================================================

The answer is the ``prediction.json`` document (:meth:`Prediction.to_dict`); the
``X-Predict-Seconds`` header says how long the model took. ``GET /health`` answers
``{"status", "model", "checkpoint", "version"}`` (the checkpoint by its run's name, never
its path on the server). Every answer that is not a prediction is a one-line JSON
``{"error": ...}`` naming the bad field or value, never a traceback.

Limits (:class:`Limits`; ``momakitchen serve`` options in brackets):

- a request body is at most 64 MB [--max-body-mb]: 413 beyond;
- the bodies of all the requests being read, waiting or predicted together are at most
  256 MB [--max-inflight-mb]: 503 with ``Retry-After`` beyond (counted from each request's
  ``Content-Length``, or the body limit without one);
- at most 4 requests wait for the model behind the one it is predicting [--queue]: 503
  with ``Retry-After`` beyond;
- a client has 30 s [--read-timeout] to send a request's headers (from its connection, or
  from the previous answer on a kept-alive one; the connection is then closed), 30 s more
  for its body (408 and the connection closed) and 30 s to take the answer;
- each image is at most 4096x4096 = 16 Mpx, checked from its PNG / JPEG / ``.npy`` header
  before anything is decoded, and every image must have the depth image's size; a
  ``.npy`` must hold bool, integer or float numbers (no structured, string or object
  arrays), as (H, W) or (H, W, C) with C <= 4, and a float colour image or mask finite
  numbers; a body or a part with a ``Content-Encoding`` is refused (415) and never
  inflated;
- a form has at most 64 fields, files included, and a text field at most 4096 bytes
  (:data:`~momakitchen.deploy.server_inputs.MAX_FIELDS`, ``MAX_TEXT_BYTES``): 413 beyond;
- a malformed request (its request line or headers, a negative ``Content-Length``, an
  overlong line in the form) is a 400 with the same one-line JSON, logged as one line;
- ``mc_samples`` <= 64 bounds the work of one frame: a frame whose client has gone is not
  predicted when its turn comes, but one already running finishes (at most 65 forward
  passes, a few seconds) before the model moves on;
- with a token (``--token`` or ``MOMAKITCHEN_SERVE_TOKEN``) every request must carry
  ``Authorization: Bearer <token>`` (401 otherwise, before its body is read); serving an
  address other than a loopback one without a token is refused.

A prediction that is not finite (a checkpoint whose weights overflow) is a 500 with a
one-line JSON naming the checkpoint; no answer ever holds NaN.

The server is `aiohttp` (asyncio): requests are read and answered concurrently while the
model runs on one worker thread, one frame at a time, so a prediction never shares torch
with another and ``/health`` answers while a frame is being predicted. The memory it holds
is the in-flight bodies (their cap) plus one frame's work (about 0.4 GB for 640x480, 2 GB
for a 16 Mpx frame). Needs the ``robot`` extra.
"""

from __future__ import annotations

import asyncio
import hmac
import ipaddress
import logging
import math
import time
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from momakitchen.deploy.server_inputs import (
    MAX_FIELDS,
    MAX_TEXT_BYTES,
    check_fields,
    predict_arguments,
)
from momakitchen.errors import MomaError

LOG = logging.getLogger("momakitchen.serve")
MAX_BODY_MB = 64  # a 640x480 float32 depth .npy is 1.2 MB; a 4K frame's fits too
MAX_INFLIGHT_MB = 256  # four full-size bodies at once
QUEUE = 4  # requests waiting for the model behind the one it predicts
READ_TIMEOUT = 30.0  # s; a 64 MB body at 20 Mbit/s takes 27 s
TOKEN_ENV = "MOMAKITCHEN_SERVE_TOKEN"


def _require_aiohttp() -> Any:
    try:
        from aiohttp import web
    except ImportError:
        raise MomaError("the server needs the robot extra: pip install -e '.[robot]'") from None
    return web


@dataclass(frozen=True)
class Limits:
    """What one server accepts (see the module docstring); MomaError names a bad one."""

    queue: int = QUEUE
    max_body_mb: int = MAX_BODY_MB
    max_inflight_mb: int = MAX_INFLIGHT_MB
    read_timeout: float = READ_TIMEOUT

    def __post_init__(self) -> None:
        if self.queue < 0:
            raise MomaError(f"the queue must be >= 0 requests, got {self.queue}")
        if self.max_body_mb < 1:
            raise MomaError(f"the body limit must be >= 1 MB, got {self.max_body_mb}")
        if self.max_inflight_mb < self.max_body_mb:
            raise MomaError(
                f"the in-flight limit ({self.max_inflight_mb} MB) must be at least the body "
                f"limit ({self.max_body_mb} MB), or a full-size request could never be read"
            )
        if not (math.isfinite(self.read_timeout) and self.read_timeout > 0):
            raise MomaError(f"the read timeout must be > 0 s, got {self.read_timeout}")


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an address or ``localhost``) serves this machine only."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:  # another name: it may resolve to any interface
        return False


def checkpoint_label(run_dir: str | Path) -> str:
    """A run directory as the server shows it: its name (``navaff (bundled)`` for the
    bundled model), never the path on the server's disk."""
    from momakitchen.train.checkpoint import DEFAULT_CHECKPOINT

    path = Path(run_dir)
    bundled = path.resolve() == DEFAULT_CHECKPOINT.resolve()
    return f"{path.name} (bundled)" if bundled else path.name


class _ClientGone(Exception):
    """The client of a queued frame left before the model got to it."""


class _Refusal(Exception):
    """A request refused while its body is read: the status and the one-line message."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


def _one_line(text: str, width: int = 200) -> str:
    """An HTTP parser's message as one line: its lines joined, the caret lines under a
    quoted header dropped, shortened to ``width``."""
    lines = [ln.strip() for ln in str(text).splitlines() if ln.strip().strip("^~")]
    joined = " ".join(" ".join(lines).split())
    return joined if len(joined) <= width else joined[: width - 3] + "..."


def _runner_class(web: Any) -> Any:
    """aiohttp's AppRunner whose connections answer what aiohttp refuses before any
    handler runs (a malformed request line or header, a negative Content-Length) as the
    one-line JSON of every other refusal, logged as one line, not a traceback."""
    from aiohttp import web_protocol

    from momakitchen.fileio import dumps_strict

    class JsonErrors(web_protocol.RequestHandler):
        __slots__ = ()

        def handle_error(
            self,
            request: Any,
            status: int = 500,
            exc: BaseException | None = None,
            message: str | None = None,
        ) -> Any:
            if request.writer.output_size > 0:  # as aiohttp: an answer is already on its way
                raise ConnectionError("an answer was sent already; cannot send the error")
            if status >= 500:  # a bug, not the client's fault: keep its traceback
                LOG.error("internal error: %r", exc, exc_info=exc)
                why = f"internal error: {type(exc).__name__}"
            else:
                why = f"malformed HTTP request: {_one_line(message or str(exc))}"
                LOG.info("refused %s: %s", request.remote, why)
            resp = web.json_response({"error": why}, status=status, dumps=dumps_strict)
            resp.force_close()
            return resp

    class JsonServer(web.Server):
        def __call__(self) -> Any:
            return JsonErrors(self, loop=self._loop, **self._kwargs)

    class Runner(web.AppRunner):
        async def _make_server(self) -> Any:
            server = await super()._make_server()
            server.__class__ = JsonServer  # the application's server, with JSON errors
            return server

    return Runner


def _no_decompression() -> dict[str, Any]:
    """The server's keyword that keeps aiohttp from inflating a request body (refused with
    415 anyway: inflating one that is not gzip logged a traceback), where it has one."""
    import inspect

    from aiohttp import web_protocol

    params = inspect.signature(web_protocol.RequestHandler.__init__).parameters
    return {"auto_decompress": False} if "auto_decompress" in params else {}


class ModelServer:
    """The loaded model, the one worker thread that runs it, and the limits.

    ``predict_defaults`` go to every :func:`momakitchen.predict` call (a request's own
    fields override them). ``token``: the bearer token every request must carry (None:
    none needed).
    """

    def __init__(
        self,
        run: Any,
        predict_defaults: Mapping[str, Any] | None = None,
        limits: Limits | None = None,
        token: str | None = None,
        method: str | None = None,
    ) -> None:
        self.run = run
        self.method = method  # a classical method served instead of a model
        self.defaults = dict(predict_defaults or {})
        self.limits = limits or Limits()
        self.token = token
        self.pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="momakitchen-model")
        self.queued = 0  # requests handed to the model thread, the running one included
        self.inflight = 0  # bytes reserved by the requests being read, queued or predicted
        self.seconds = 1.0  # a running mean of the model's time, for Retry-After
        self.unseen: set[Any] = set()  # connections that have sent no request head yet

    def health(self) -> dict[str, Any]:
        from momakitchen.version import __version__

        if self.method is not None:
            return {"status": "ok", "model": self.method, "version": __version__}
        return {
            "status": "ok",
            "model": self.run.config.model,
            "checkpoint": checkpoint_label(self.run.run_dir),
            "version": __version__,
        }

    def predict(
        self, files: Mapping[str, list[bytes]], text: Mapping[str, str]
    ) -> tuple[dict, float]:
        """The prediction.json document of one request and the model's seconds."""
        from momakitchen.deploy.predict import predict

        kwargs, floor = predict_arguments(files, text)
        t0 = time.perf_counter()
        if self.method is not None:  # a classical method: no model, no MC-dropout
            from momakitchen.placement.methods import place

            args = {**self.defaults, **kwargs}
            for name in ("mc_samples", "threads", "opens"):  # a model's only
                args.pop(name, None)
            pred = place(self.method, **args)
        else:
            mount = kwargs.pop("mount_height", None)
            if mount is not None:  # the robot, by name, at that mount
                kwargs["robot"] = (kwargs["robot"], mount)
            pred = predict(**{**self.defaults, **kwargs}, checkpoint=self.run)
        return pred.to_dict(floor_points=floor), time.perf_counter() - t0

    def _job(
        self, files: Mapping[str, list[bytes]], text: Mapping[str, str], alive: Callable
    ) -> tuple[str, float]:
        """On the model thread: the answer's JSON text, unless the client has left."""
        from momakitchen.fileio import dumps_strict

        if not alive():  # its client gave up while it waited: do not spend the model on it
            raise _ClientGone
        doc, seconds = self.predict(files, text)
        return dumps_strict(doc), seconds

    def retry_after(self) -> str:
        """Seconds until the queue has likely moved on (for a 503's Retry-After)."""
        return str(max(1, math.ceil(self.seconds * max(self.queued, 1))))

    def app(self) -> Any:
        """The aiohttp application."""
        from momakitchen.fileio import dumps_strict
        from momakitchen.models.inference import NonFiniteOutput

        web = _require_aiohttp()
        limits = self.limits
        max_body = limits.max_body_mb * 1024 * 1024
        inflates = not _no_decompression()  # an aiohttp that inflates every encoded body

        def error(status: int, message: str, **headers: str) -> Any:
            doc = {"error": " ".join(message.split())}
            return web.json_response(doc, status=status, headers=headers, dumps=dumps_strict)

        def busy(why: str) -> Any:
            headers = {"Retry-After": self.retry_after()}
            return error(503, f"the server is busy ({why}); retry later", **headers)

        async def send(request: Any, resp: Any) -> Any:
            """Write the answer here, so that a client that does not read it is cut off."""
            try:
                await asyncio.wait_for(_write(request, resp), limits.read_timeout)
            except asyncio.TimeoutError:
                request.protocol.force_close()
            except ConnectionError:  # the client left: nothing to tell anyone
                pass
            encoded = resp.status == 415 and "Content-Encoding" in request.headers
            if (resp.status == 408 or (inflates and encoded)) and request.protocol is not None:
                # now, rather than after aiohttp's wait for the rest of the body (10 s), in
                # which it would inflate a refused body
                request.protocol.force_close()
            return resp

        async def _write(request: Any, resp: Any) -> None:
            await resp.prepare(request)
            await resp.write_eof()

        @web.middleware
        async def guard(request: Any, handler: Any) -> Any:
            self.unseen.discard(request.protocol)
            given = request.headers.get("Authorization", "")
            if self.token is not None and not hmac.compare_digest(
                given.encode(), f"Bearer {self.token}".encode()
            ):
                resp = error(
                    401,
                    "this server needs 'Authorization: Bearer <token>'"
                    + (" (the token given is wrong)" if given else ""),
                    **{"WWW-Authenticate": "Bearer"},
                )
            else:
                try:
                    resp = await handler(request)
                except web.HTTPException as exc:  # 404, 405: one line of JSON as well
                    allow = {"Allow": exc.headers["Allow"]} if "Allow" in exc.headers else {}
                    why = f"{exc.reason}: {request.method} {request.path}"
                    resp = error(exc.status, why, **allow)
            return await send(request, resp)

        async def health(_: Any) -> Any:
            return web.json_response(self.health(), dumps=dumps_strict)

        async def predict(request: Any) -> Any:
            if not request.content_type.startswith("multipart/"):
                return error(415, "send the frame as multipart/form-data")
            encoding = request.headers.get("Content-Encoding", "identity").lower()
            if encoding != "identity":
                return error(415, f"Content-Encoding {encoding!r} is not accepted: send it plain")
            size = request.content_length
            if size is not None and size > max_body:
                return error(413, f"the request is larger than {limits.max_body_mb} MB")
            # Refused before the body is read, so that a busy server reads nothing it drops.
            if self.queued > limits.queue:
                return busy(f"the model's queue is full: {limits.queue} waiting")
            reserve = max_body if size is None else size
            if self.inflight + reserve > limits.max_inflight_mb * 1024 * 1024:
                return busy(f"{limits.max_inflight_mb} MB of requests are in flight")
            self.inflight += reserve
            try:
                return await receive_and_predict(request)
            finally:
                self.inflight -= reserve

        async def read_form(
            request: Any, files: dict[str, list[bytes]], text: dict[str, str]
        ) -> None:
            """The form's parts into ``files`` and ``text``, each limit checked as the
            parts arrive; _Refusal otherwise."""
            from aiohttp import BodyPartReader

            reader = await request.multipart()
            count = 0
            while (part := await reader.next()) is not None:
                count += 1
                if count > MAX_FIELDS:
                    raise _Refusal(413, f"the form has more than {MAX_FIELDS} fields (the limit)")
                if not isinstance(part, BodyPartReader):
                    raise _Refusal(400, "malformed multipart body: a nested multipart part")
                name = part.name
                if not name:
                    raise _Refusal(400, "malformed multipart body: a part without a name")
                for header in ("Content-Encoding", "Content-Transfer-Encoding"):
                    # never decoded: a compressed part could be any size once inflated
                    coding = part.headers.get(header, "identity").lower()
                    if coding not in ("identity", "binary", "7bit", "8bit"):
                        raise _Refusal(
                            415, f"field {name[:40]!r} has {header} {coding[:40]!r}: send it plain"
                        )
                data = bytearray()
                while chunk := await part.read_chunk():
                    data.extend(chunk)
                    if request.content.total_bytes > max_body:  # a body without a length
                        raise _Refusal(413, f"the request is larger than {limits.max_body_mb} MB")
                    if part.filename is None and len(data) > MAX_TEXT_BYTES:
                        raise _Refusal(
                            413,
                            f"text field {name[:40]!r} is over {MAX_TEXT_BYTES} bytes (the "
                            "limit of a text field)",
                        )
                if part.filename is not None:
                    files.setdefault(name, []).append(bytes(data))
                elif name in text:
                    raise _Refusal(400, f"field {name[:40]!r} is given more than once")
                else:
                    try:
                        text[name] = data.decode("utf-8")
                    except UnicodeDecodeError:
                        raise _Refusal(400, f"field {name[:40]!r} is not UTF-8 text") from None

        async def receive_and_predict(request: Any) -> Any:
            from aiohttp.http_exceptions import HttpProcessingError

            files: dict[str, list[bytes]] = {}
            text: dict[str, str] = {}
            try:
                await asyncio.wait_for(read_form(request, files, text), limits.read_timeout)
            except _Refusal as exc:
                return error(exc.status, exc.message)
            except asyncio.TimeoutError:
                return error(408, f"the body did not arrive within {limits.read_timeout:g} s")
            except web.HTTPRequestEntityTooLarge:
                return error(413, f"the request is larger than {limits.max_body_mb} MB")
            except ConnectionError:  # the client left mid-body
                return error(400, "the connection was lost")
            except HttpProcessingError as exc:  # a line too long, too many part headers
                return error(400, f"malformed multipart body: {_one_line(exc.message)}")
            except (ValueError, AssertionError, RuntimeError) as exc:
                return error(400, f"malformed multipart body: {_one_line(str(exc))}")
            try:
                check_fields(files, text)  # here, so that a bad request does not wait its turn
            except MomaError as exc:
                return error(400, str(exc))
            if self.queued > limits.queue:
                return busy(f"the model's queue is full: {limits.queue} waiting")

            def alive() -> bool:
                transport = request.transport
                return transport is not None and not transport.is_closing()

            loop = asyncio.get_running_loop()
            self.queued += 1
            try:
                body, seconds = await loop.run_in_executor(self.pool, self._job, files, text, alive)
            except _ClientGone:
                return error(400, "the client left before its turn")
            except NonFiniteOutput as exc:
                LOG.error("%s", " ".join(str(exc).split()))
                return error(
                    500,
                    f"checkpoint {checkpoint_label(exc.checkpoint)!r} gave non-finite "
                    "affordances (NaN or infinity) for this frame: its weights are broken; "
                    "serve another checkpoint",
                )
            except MomaError as exc:
                return error(400, str(exc))
            except Exception as exc:  # a bug, not the client's fault: log it, answer one line
                LOG.exception("prediction failed")
                return error(500, f"internal error: {type(exc).__name__}: {exc}")
            finally:
                self.queued -= 1
            self.seconds = 0.8 * self.seconds + 0.2 * seconds
            return web.Response(
                text=body,
                content_type="application/json",
                headers={"X-Predict-Seconds": f"{seconds:.4f}"},
            )

        app = web.Application(client_max_size=max_body, middlewares=[guard])
        app.router.add_get("/health", health)
        app.router.add_post("/predict", predict)

        async def close(_: Any) -> None:
            self.pool.shutdown(wait=False, cancel_futures=True)

        app.on_cleanup.append(close)
        return app

    async def start(self, host: str, port: int) -> Any:
        """Listen on ``host:port`` (0: any free port); returns the aiohttp runner (its
        ``addresses`` say where; ``cleanup()`` stops it)."""
        web = _require_aiohttp()
        # keepalive_timeout: an idle connection, or one trickling its next request's
        # head, is closed after the read timeout
        runner = _runner_class(web)(
            self.app(),
            access_log=None,
            keepalive_timeout=self.limits.read_timeout,
            **_no_decompression(),
        )
        await runner.setup()
        self.watch(runner.server)
        site = web.TCPSite(runner, host, port)
        try:
            await site.start()
        except OSError as exc:
            await runner.cleanup()
            raise MomaError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
        return runner

    def watch(self, server: Any) -> None:
        """Close each connection of aiohttp's ``server`` that has not sent a complete
        request head within the read timeout (aiohttp's keep-alive timer covers the time
        between requests, and not, before 3.14, a connection's first request)."""
        loop = asyncio.get_running_loop()
        made = server.connection_made

        def expire(handler: Any) -> None:
            if handler in self.unseen:
                self.unseen.discard(handler)
                handler.force_close()

        def connection_made(handler: Any, transport: Any) -> None:
            made(handler, transport)
            self.unseen.add(handler)
            loop.call_later(self.limits.read_timeout, expire, handler)

        server.connection_made = connection_made


def serve(
    host: str = "127.0.0.1",
    port: int = 8000,
    checkpoint: Any = None,
    predict_defaults: Mapping[str, Any] | None = None,
    ready: Any = None,
    limits: Limits | None = None,
    token: str | None = None,
    method: str | None = None,
) -> None:
    """Load the model (or a classical ``method``: ``ring``, ``reachability``) and serve
    until interrupted. ``ready(host, port)`` is called once
    the socket listens. A ``host`` that is not a loopback address needs a ``token``."""
    from momakitchen.train.checkpoint import LoadedRun, default_checkpoint, load_checkpoint

    _require_aiohttp()
    if token is not None and not token.strip():
        raise MomaError("the token is empty: give a secret, or no token on a loopback address")
    if token is None and not is_loopback(host):
        raise MomaError(
            f"refusing to serve {host} without a token: anyone who reaches it could use the "
            f"model; give --token or set {TOKEN_ENV} (or serve 127.0.0.1 only)"
        )
    limits = limits or Limits()
    if method is not None:
        from momakitchen.placement.methods import CLASSICAL_METHODS

        if method not in CLASSICAL_METHODS:
            raise MomaError(
                f"unknown method {method!r}; serve takes {', '.join(CLASSICAL_METHODS)}"
            )
        if checkpoint is not None:
            raise MomaError("give a checkpoint or a classical method to serve, not both")
        server = ModelServer(None, predict_defaults, limits, token, method)
    else:
        run = (
            checkpoint
            if isinstance(checkpoint, LoadedRun)
            else load_checkpoint(checkpoint if checkpoint is not None else default_checkpoint())
        )
        server = ModelServer(run, predict_defaults, limits, token)

    async def main() -> None:
        runner = await server.start(host, port)
        try:
            if ready is not None:
                bound = runner.addresses[0][1] if runner.addresses else port
                ready(host, bound)
            await asyncio.Event().wait()  # until cancelled (Ctrl-C)
        finally:
            await runner.cleanup()

    asyncio.run(main())
