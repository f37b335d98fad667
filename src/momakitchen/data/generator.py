"""Dataset generation: run a per-scene producer over many scenes, in parallel, resumably.

A *producer* is a function ``scene_fn(scene_id, config) -> records`` (records: a list of
``(ConfigurationLabels, [Episode, ...])``, one entry per configuration) that is
deterministic in ``(scene_id, config)``; the default is
:func:`momakitchen.generation.producer.scene_records` with its ``GenerationConfig``.
Each scene becomes one shard written atomically by :func:`momakitchen.data.shard.write_shard`,
so a run killed at any point leaves only complete shards (plus hidden temporary files that
the next run deletes) and the next run computes only the missing scenes. Because shards
depend only on ``(scene_id, config)``, the dataset is the same for any worker count or
backend.

Backends: ``local`` (a process pool with the spawn start method; each worker computes and
writes whole scenes) and ``ray`` (the same per-scene function as Ray tasks; the task returns
the shard's bytes and the driver writes them, so no shared file system is needed).

User robots (URDF + YAML, :mod:`momakitchen.robots.user`) registered in the generating
process are registered again in every worker (the pool's initializer, each Ray task) from
the same YAML paths, their content hashes checked; the manifest records those the config
uses (``user_robots``: name, YAML path, sha256), so that readers can say which files to
register. On Ray the files must be at the same paths on every node.
"""

from __future__ import annotations

import ctypes
import dataclasses
import fcntl
import functools
import inspect
import multiprocessing
import os
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from tqdm import tqdm

from momakitchen.data import manifest as mf
from momakitchen.data.producers import (  # noqa: F401  (importable from here too)
    PRODUCERS,
    Producer,
    _first_difference,
    config_class,
    config_dict,
    producer_name,
)
from momakitchen.data.shard import (
    SCENES_DIR,
    SceneRecords,
    SceneShard,
    file_sha256,
    file_summary,
    list_shards,
    remove_temporaries,
    shard_bytes,
    write_shard,
    write_shard_bytes,
)
from momakitchen.errors import MomaError
from momakitchen.robots.spec import DESCRIPTOR_VERSION
from momakitchen.scene.ids import check_scene_range
from momakitchen.version import __version__

BACKENDS = ("local", "ray")
SceneFn = Callable[[int, Any], SceneRecords]
LOCK_NAME = ".generate.lock"
MANIFEST_SAVE_SECONDS = 5.0


@dataclasses.dataclass(frozen=True)
class GenerateRequest:
    """What to generate.

    Attributes:
        out: dataset root (created if missing; must be empty or an existing dataset).
        num_scenes: number of scenes, ids ``first_scene_id .. first_scene_id + num_scenes - 1``.
        first_scene_id: first scene id.
        workers: parallel workers (processes for ``local``, CPUs for a local Ray instance).
        backend: one of ``BACKENDS``.
        split: None for every scene of the range, or ``"train"`` / ``"test"`` for only
            that split's scenes (e.g. the test scenes, to evaluate a trained model; a later
            run without a split adds the rest, shard for shard as one run would make them).
    """

    out: Path
    num_scenes: int
    first_scene_id: int = 0
    workers: int = 1
    backend: str = "local"
    split: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.num_scenes, int) or self.num_scenes < 1:
            raise MomaError(f"number of scenes must be >= 1, got {self.num_scenes!r}")
        if not isinstance(self.first_scene_id, int) or self.first_scene_id < 0:
            raise MomaError(f"first scene id must be >= 0, got {self.first_scene_id!r}")
        check_scene_range(self.first_scene_id, self.num_scenes)
        if not isinstance(self.workers, int) or not 1 <= self.workers <= 1024:
            raise MomaError(f"workers must be in [1, 1024], got {self.workers!r}")
        if self.backend not in BACKENDS:
            raise MomaError(f"backend must be one of {BACKENDS}, got {self.backend!r}")
        if self.split is not None and self.split not in mf.SPLITS:
            raise MomaError(f"split must be one of {mf.SPLITS}, got {self.split!r}")
        if not self.scene_ids:
            last = self.first_scene_id + self.num_scenes - 1
            raise MomaError(
                f"no {self.split} scene among ids {self.first_scene_id}..{last} "
                f"(one id in {mf.SPLIT_BLOCK} is a test scene); ask for more scenes"
            )

    @property
    def scene_ids(self) -> list[int]:
        return mf.requested_scene_ids(self.first_scene_id, self.num_scenes, self.split)


def prepare_root(
    root: Path,
    producer: str,
    config: dict[str, Any],
    cls: str,
    user_robots: list[dict[str, str]] | None = None,
) -> dict[str, Any]:
    """The manifest to continue from: a new one for an empty/missing root, the existing one
    if it was made by the same producer, config, user robots (by content hash) and
    generator version; else MomaError."""
    user_robots = user_robots or []
    if root.exists() and not root.is_dir():
        raise MomaError(f"--out {str(root)!r} exists and is not a directory")
    if mf.manifest_path(root).is_file():
        old = mf.load_manifest(root)
        if old.get("producer") != producer:
            raise MomaError(
                f"{root} was generated by {old.get('producer')!r}, not {producer!r};"
                " use another --out"
            )
        diff = (
            "config_class"
            if old.get("config_class") != cls
            else _first_difference(old.get("config"), config)
        )
        if diff:
            raise MomaError(
                f"{root} was generated with a different configuration (first "
                f"difference: {diff}); use another --out or the same settings"
            )
        before = {r["name"]: r["sha256"] for r in mf.manifest_user_robots(old, root)}
        now = {r["name"]: r["sha256"] for r in user_robots}
        if before != now:
            changed = sorted(set(before.items()) ^ set(now.items()))[0][0]
            raise MomaError(
                f"{root} was generated with other user robot files (first difference: "
                f"robot {changed!r}); use another --out or the same --robot-yaml files"
            )
        if old.get("generator_version") != __version__:
            raise MomaError(
                f"{root} was generated by momakitchen "
                f"{old.get('generator_version')}, this is {__version__}; "
                "use another --out"
            )
        return old
    if root.is_dir():
        # A run killed before it saved its first manifest leaves only the lock file and a
        # scenes/ folder without finished shards: that is still ours to continue.
        ours = {LOCK_NAME} | ({SCENES_DIR} if not list_shards(root) else set())
        others = sorted(p.name for p in root.iterdir() if p.name not in ours)
        if others:
            raise MomaError(
                f"--out {str(root)!r} is a non-empty directory without a "
                f"{mf.MANIFEST_NAME} (holds {others[0]!r}); refusing to write there"
            )
    return mf.new_manifest(producer, config, cls, user_robots)


@contextmanager
def _locked(root: Path) -> Iterator[None]:
    """Exclusive lock on the dataset root; released by the kernel even on SIGKILL. The
    lock file is removed when the run ends, so a finished dataset holds none (one killed
    mid-run keeps it; the next run takes it over)."""
    path = root / LOCK_NAME
    fh = open(path, "a")
    try:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise MomaError(f"another 'momakitchen generate' is writing to {root}") from None
        # A run that ended just now may have removed the file we opened: the lock must be
        # on the file at ``path``, or a later run would lock another one beside us.
        if not path.exists() or os.stat(path).st_ino != os.fstat(fh.fileno()).st_ino:
            raise MomaError(f"another 'momakitchen generate' is writing to {root}")
        try:
            yield
        finally:
            path.unlink(missing_ok=True)  # while still holding the lock
    finally:
        fh.close()


def _existing_summary(path: Path, known: dict[str, Any] | None) -> dict[str, Any]:
    """Summary of a finished shard from an earlier run (trusted from the manifest when its
    size matches, else read from the shard and hashed)."""
    if known is not None and known.get("bytes") == path.stat().st_size:
        return {k: v for k, v in known.items() if k != "split"}
    with SceneShard(path) as shard:
        configs = [shard.configuration(c) for c in shard.config_indices()]
        per_config = [len(shard.episode_indices(c)) for c in shard.config_indices()]
        covering = [shard.covering_views(c) for c in shard.config_indices()]
        points = [
            [shard.num_points(c, e) for e in shard.episode_indices(c)]
            for c in shard.config_indices()
        ]
    return {
        "scene_id": shard.scene_id,
        "configurations": len(configs),
        "episodes_per_config": per_config,
        "robots": [c.robot for c in configs],
        "targets": [c.target for c in configs],
        "trials": [int(c.trial_stages.shape[0]) for c in configs],
        "successes": [int((c.trial_stages == 0).sum()) for c in configs],
        "feasible": [c.feasible for c in configs],
        "covering_views": covering,
        "global_points": [[g for g, _ in eps] for eps in points],
        "floor_points": [[f for _, f in eps] for eps in points],
        "file": f"{SCENES_DIR}/{path.name}",
        "bytes": path.stat().st_size,
        "sha256": file_sha256(path),
    }


def reports_progress(scene_fn: SceneFn) -> bool:
    """Whether a producer takes the optional ``progress(done, total)`` keyword that it calls
    after each configuration (the built-in producers do; a user's need not)."""
    try:
        return "progress" in inspect.signature(scene_fn).parameters
    except (TypeError, ValueError):  # a callable without a signature
        return False


def _records(
    scene_fn: SceneFn,
    config: Any,
    scene_id: int,
    progress: Callable[[int, int], None] | None,
) -> SceneRecords:
    """The producer's records of a scene, passing ``progress`` on where it is taken."""
    if progress is not None and reports_progress(scene_fn):
        return scene_fn(scene_id, config, progress=progress)  # type: ignore[call-arg]
    return scene_fn(scene_id, config)


# In a pool worker: the queue on which it reports (scene id, configurations done, total).
_WORKER_PROGRESS: Any = None


# In a pool worker: why registering the driver's user robots failed (raised by each task:
# an initializer's exception would only break the pool, without its message).
_WORKER_ERROR: MomaError | None = None


def _scene_task(
    scene_fn: SceneFn,
    config: Any,
    scene_id: int,
    directory: str,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Worker body (local backend): compute one scene and write its shard. In a pool worker
    the progress goes to the driver through the queue given to :func:`_worker_init`."""
    if _WORKER_ERROR is not None:
        raise _WORKER_ERROR
    reports = _WORKER_PROGRESS
    if progress is None and reports is not None:

        def progress(done: int, total: int) -> None:
            reports.put((scene_id, done, total))

    return write_shard(directory, scene_id, _records(scene_fn, config, scene_id, progress))


def _worker_init(
    parent_pid: int, progress_queue: Any = None, robot_files: tuple[dict[str, str], ...] = ()
) -> None:
    """Pool worker start-up: keep the progress queue, register the driver's user robots
    (``robot_files``: :meth:`UserRobotFile.to_dict` records), and exit as soon as the
    generating process is gone. Workers of a SIGKILLed run would otherwise wait for work
    forever (and finish queued scenes while a resumed run writes the same directory)."""
    global _WORKER_PROGRESS, _WORKER_ERROR
    _WORKER_PROGRESS = progress_queue
    try:
        _register_robots(robot_files)
    except MomaError as exc:
        _WORKER_ERROR = exc

    if sys.platform.startswith("linux"):
        # The kernel kills the worker the moment the driver dies: no orphan can write a
        # temporary shard after a resumed run has cleaned up (PR_SET_PDEATHSIG = 1).
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)
    if os.getppid() != parent_pid:  # the driver died before the line above took effect
        os._exit(1)

    def watch() -> None:  # elsewhere: poll (a worker busy in C code notices later)
        while os.getppid() == parent_pid:
            time.sleep(0.5)
        os._exit(1)  # its temporary shard, if any, is removed by the next run

    threading.Thread(target=watch, daemon=True, name="momakitchen-parent-watch").start()


def _register_robots(robot_files: tuple[dict[str, str], ...]) -> None:
    """Register the user robots of ``robot_files`` here (a worker), checking their hashes."""
    if robot_files:
        from momakitchen.robots.user import UserRobotFile, register_recorded

        register_recorded(UserRobotFile.from_dict(r) for r in robot_files)


def _user_robot_files(config: Any) -> tuple[list[dict[str, str]], tuple[dict[str, str], ...]]:
    """``(recorded, for workers)``: the records of the user robots that ``config`` uses
    (its ``scene.robot_names``; for the manifest) and of every user robot registered here
    (registered again in each worker, as here)."""
    from momakitchen.robots.spec import ROBOTS
    from momakitchen.robots.user import user_robot_files

    scene = getattr(config, "scene", None)
    used = getattr(scene, "robot_names", ())
    recorded = [f.to_dict() for f in user_robot_files(used)]
    return recorded, tuple(f.to_dict() for f in user_robot_files(ROBOTS))


def _scene_bytes_task(
    scene_fn: SceneFn, config: Any, scene_id: int, robot_files: tuple[dict[str, str], ...] = ()
) -> tuple[dict, bytes]:
    """Worker body (Ray backend): register the driver's user robots (``robot_files``),
    compute one scene, return the shard summary and bytes."""
    _register_robots(robot_files)
    records = scene_fn(scene_id, config)
    data = shard_bytes(scene_id, records)
    return file_summary(scene_id, records, data), data


def generate_dataset(
    request: GenerateRequest,
    scene_fn: SceneFn,
    config: Any,
    *,
    progress: bool = True,
    write_card: bool = True,
) -> dict[str, Any]:
    """Generate (or resume) the dataset described by ``request``; returns the manifest.

    ``scene_fn`` makes the records of a scene from its id and ``config`` (the simulator's:
    :func:`momakitchen.generation.producer.scene_records`). Existing complete
    shards are kept and skipped, temporary files from killed runs are removed; the
    manifest is saved every few seconds and at the end, then the dataset card is rewritten.
    """
    producer = producer_name(scene_fn)
    cfg = config_dict(config)
    root = Path(request.out)
    recorded, robot_files = _user_robot_files(config)
    manifest = prepare_root(root, producer, cfg, config_class(config), recorded)
    submit, ray_started = (
        _ray_submitter(request.workers) if request.backend == "ray" else (None, False)
    )
    try:
        root.mkdir(parents=True, exist_ok=True)
        (root / SCENES_DIR).mkdir(exist_ok=True)
    except OSError as exc:
        raise MomaError(f"cannot create dataset directory {str(root)!r}: {exc.strerror}") from None

    with _locked(root):
        remove_temporaries(root)
        existing = list_shards(root)
        known = manifest["shards"]
        # Entries whose shard file is gone are dropped (they will be regenerated).
        for key in [k for k in known if int(k) not in existing]:
            del known[key]
        for sid, path in existing.items():
            manifest_entry = known.get(str(sid))
            try:
                mf.add_shard(manifest, _existing_summary(path, manifest_entry))
            except MomaError as exc:
                raise MomaError(f"{exc}; delete that file to regenerate the scene") from None
        todo = [s for s in request.scene_ids if s not in existing]
        if todo and manifest.get("descriptor_version") != DESCRIPTOR_VERSION:
            # Read as current, but never extended: one dataset, one stored layout.
            raise MomaError(
                f"{root} was generated with robot descriptor version "
                f"{manifest.get('descriptor_version')}, this version of momakitchen writes "
                f"{DESCRIPTOR_VERSION}; its {len(todo)} missing scene(s) need another --out"
            )
        mf.record_request(manifest, request.first_scene_id, request.num_scenes, request.split)
        mf.save_manifest(root, mf.finalize(manifest, complete=False))

        # A scene is the unit of work: never more workers than scenes left to make.
        workers = max(1, min(request.workers, len(todo)))
        bar = tqdm(
            total=len(request.scene_ids),
            initial=len(request.scene_ids) - len(todo),
            desc=f"generate ({workers} worker{'s' if workers > 1 else ''})",
            unit="scene",
            # Scenes advance by configurations: a fraction of a scene, with one decimal.
            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total_fmt} scenes "
            "[{elapsed}<{remaining}{postfix}]",
            disable=not progress,
            file=sys.stderr,
            dynamic_ncols=True,
        )
        last_save = time.monotonic()
        finished = len(request.scene_ids) - len(todo)  # requested scenes with a shard
        episodes = configurations = 0  # of the scenes written by this run
        running: dict[int, tuple[int, int]] = {}  # scene -> (configurations done, of)

        def redraw() -> None:
            # The position is recomputed, not accumulated: summed fractions drift past the
            # total in floating point.
            position = finished + sum(d / t for d, t in running.values())
            in_progress = sum(d for d, _ in running.values())
            # Episodes are known only once a scene's shard is written (producers report
            # configurations): shown from then on, as those of the written scenes.
            written = f", episodes written={episodes}" if episodes else ""
            bar.set_postfix_str(
                f"configurations={configurations + in_progress}{written}", refresh=False
            )
            bar.update(position - bar.n)
            bar.n = position

        def partial(scene_id: int, done_configs: int, total: int) -> None:
            if str(scene_id) in manifest["shards"]:
                return  # a late report of a scene already written
            running[scene_id] = (done_configs, max(total, 1))
            redraw()

        def done(summary: dict[str, Any]) -> None:
            nonlocal last_save, finished, episodes, configurations
            mf.add_shard(manifest, summary)
            running.pop(int(summary["scene_id"]), None)
            finished += 1
            episodes += sum(summary["episodes_per_config"])
            configurations += summary["configurations"]
            redraw()
            if time.monotonic() - last_save > MANIFEST_SAVE_SECONDS:
                mf.save_manifest(root, mf.finalize(manifest, complete=False))
                last_save = time.monotonic()

        try:
            if todo and request.backend == "ray":
                _run_ray(submit, scene_fn, config, todo, root, done, robot_files)
            elif todo:
                _run_local(scene_fn, config, todo, root, workers, done, partial, robot_files)
        finally:
            bar.close()
            mf.save_manifest(
                root,
                mf.finalize(
                    manifest, complete=all(str(s) in manifest["shards"] for s in request.scene_ids)
                ),
            )
            if ray_started:
                import ray

                ray.shutdown()
    if write_card:
        from momakitchen.data.card import write_dataset_card

        write_dataset_card(root, manifest)
    return manifest


def _run_local(
    scene_fn: SceneFn,
    config: Any,
    todo: list[int],
    root: Path,
    workers: int,
    done: Callable[[dict[str, Any]], None],
    partial: Callable[[int, int, int], None] | None = None,
    robot_files: tuple[dict[str, str], ...] = (),
) -> None:
    """Make the scenes of ``todo`` in ``workers`` processes (here if 1); ``done(summary)``
    as each shard is written, ``partial(scene id, configurations done, total)`` as the
    producer reports them. Each worker registers the user robots of ``robot_files``."""
    directory = str(root / SCENES_DIR)
    if workers == 1:
        for sid in todo:
            report = None if partial is None else functools.partial(partial, sid)
            done(_scene_task(scene_fn, config, sid, directory, report))
        return
    # Spawn: PyBullet and h5py state must not be inherited through fork.
    ctx = multiprocessing.get_context("spawn")
    reports = ctx.Queue() if partial is not None and reports_progress(scene_fn) else None

    def drain() -> None:
        while reports is not None and partial is not None:
            try:
                partial(*reports.get_nowait())
            except queue.Empty:
                return

    with ProcessPoolExecutor(
        max_workers=min(workers, len(todo)),
        mp_context=ctx,
        initializer=_worker_init,
        initargs=(os.getpid(), reports, robot_files),
    ) as pool:
        pending = {pool.submit(_scene_task, scene_fn, config, sid, directory) for sid in todo}
        try:
            while pending:
                finished, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
                drain()
                for fut in finished:
                    done(fut.result())
        except BaseException:
            for fut in pending:
                fut.cancel()
            _stop_workers(pool)
            raise


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """End the pool's workers now. Leaving the ``with`` block would wait for each to finish
    its scene (a minute or more) when only this process was interrupted (``kill -INT``, an
    IDE's stop button: Ctrl-C in a terminal reaches the workers too); their temporary
    shards are removed by the next run."""
    # The executor has no public way to end running tasks: its worker processes (taken
    # before shutdown, which forgets them).
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join(timeout=5)


def _ray_submitter(workers: int) -> tuple[Any, bool]:
    """Initialise Ray (an existing cluster via RAY_ADDRESS, else a local instance with
    ``workers`` CPUs); return the remote version of the per-scene task and whether Ray was
    initialised here (then it is shut down at the end)."""
    try:
        import ray
    except ImportError:
        raise MomaError(
            "--backend ray needs Ray: pip install 'momakitchen[ray]' (or pip install 'ray>=2.9')"
        ) from None
    started = not ray.is_initialized()
    if started:
        address = os.environ.get("RAY_ADDRESS")
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
    return ray.remote(num_cpus=1)(_scene_bytes_task), started


def _run_ray(
    remote: Any,
    scene_fn: SceneFn,
    config: Any,
    todo: list[int],
    root: Path,
    done: Callable[[dict[str, Any]], None],
    robot_files: tuple[dict[str, str], ...] = (),
) -> None:
    import ray

    scenes = root / SCENES_DIR
    pending = [remote.remote(scene_fn, config, sid, robot_files) for sid in todo]
    while pending:
        finished, pending = ray.wait(pending, num_returns=1)
        for ref in finished:
            summary, data = ray.get(ref)
            path = write_shard_bytes(scenes, summary["scene_id"], data)
            if file_sha256(path) != summary["sha256"]:
                path.unlink()
                raise MomaError(f"shard {path.name}: bytes changed in transfer from Ray")
            summary["file"] = f"{SCENES_DIR}/{path.name}"
            done(summary)
