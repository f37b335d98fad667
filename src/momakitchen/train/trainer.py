"""The training loop: Adam + cosine decay, checkpoints and resume, CSV log, loss curve, DDP.

``train(config, train_set, val_set, out_dir)`` takes torch Datasets that follow the batch
contract (:mod:`momakitchen.data.batch`), so the same loop trains on synthetic episodes or
on the HDF5 dataset. Under ``torchrun`` (``WORLD_SIZE`` > 1) it joins a gloo process group,
wraps the model in DistributedDataParallel and shards the training set by sample with a
DistributedSampler; rank 0 validates, logs and writes checkpoints.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sized
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast

import torch
import torch.distributed as dist
from torch.nn.parallel import DistributedDataParallel
from torch.utils.data import DataLoader, Dataset, DistributedSampler, Sampler
from tqdm.auto import tqdm

from momakitchen.data.batch import EpisodeCollator, episode_maps
from momakitchen.data.config import Preprocessing
from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_bytes, atomic_write_text
from momakitchen.metrics import map_metrics
from momakitchen.models.base import AffordanceModel, PlanningCollator
from momakitchen.models.registry import build_model, get_model_entry
from momakitchen.perception.clouds import reuse_freed_memory
from momakitchen.train.checkpoint import (
    WEIGHTS_FILE,
    dataset_preprocessing,
    dataset_shards,
    dataset_view_distance,
    has_checkpoint,
    load_trainer_state,
    load_weights,
    read_run_config,
    record_train_data,
    require_checkpoint,
    run_preprocessing,
    save_trainer_state,
    save_weights,
    write_run_config,
)
from momakitchen.train.config import TrainConfig

LOG_FILE = "log.csv"
CURVE_FILE = "loss_curve.png"
LOG_COLUMNS = (
    "kind",
    "epoch",
    "step",
    "lr",
    "loss",
    "mse",
    "val_loss",
    "val_mae",
    "val_rmse",
    "val_pcc",
    "val_sim",
    "samples",
    "samples_per_s",
    "seconds",
)


@dataclass
class TrainResult:
    """What :func:`train` returns (on every rank; ``history`` is complete on rank 0)."""

    run_dir: Path
    model: AffordanceModel
    history: list[dict[str, Any]] = field(default_factory=list)
    global_step: int = 0
    stopped_by: str | None = None  # "SIGTERM"/"SIGINT": checkpointed early, not finished


def cosine_lr(config: TrainConfig, step: int, total_steps: int) -> float:
    """Learning rate at ``step`` (0-based) of ``total_steps``: a linear rise over
    ``config.warmup_steps``, then a cosine from lr to lr * min_lr_ratio."""
    warm = min(config.warmup_steps, total_steps)
    if step < warm:
        return config.lr * (step + 1) / warm
    t = min(step - warm, total_steps - warm) / max(total_steps - warm, 1)
    floor = config.lr * config.min_lr_ratio
    return floor + (config.lr - floor) * 0.5 * (1.0 + math.cos(math.pi * t))


def _dist_setup() -> tuple[int, int, bool]:
    world = int(os.environ.get("WORLD_SIZE", "1"))
    created = False
    if world > 1 and not dist.is_initialized():
        dist.init_process_group("gloo")
        created = True
    if dist.is_initialized():
        return dist.get_rank(), dist.get_world_size(), created
    return 0, 1, created


class _SkipSampler(Sampler[int]):
    """``sampler``'s indices less the first ``skip`` (set before each epoch): a run resumed
    within an epoch reads only the samples it has not trained on yet."""

    def __init__(self, sampler: Sampler[int]) -> None:
        self.sampler = sampler
        self.skip = 0

    def __iter__(self) -> Iterator[int]:
        return itertools.islice(iter(self.sampler), self.skip, None)

    def __len__(self) -> int:
        return max(len(cast(Sized, self.sampler)) - self.skip, 0)


def _rank0_flags(world: int, *flags: bool) -> tuple[bool, ...]:
    """Rank 0's ``flags`` on every rank: its clock and the signals it got decide when a
    checkpoint is written and when the run stops (every rank takes part in both)."""
    if world == 1:
        return flags
    tensor = torch.tensor([int(f) for f in flags])
    dist.broadcast(tensor, 0)
    return tuple(bool(v) for v in tensor.tolist())


class _StopSignals:
    """While entered, the first SIGTERM or SIGINT is recorded (``requested``) instead of
    killing the run, so the loop can write a checkpoint and return; a second one acts as
    it would have (the previous handler is back). Outside the main thread, a no-op."""

    SIGNALS = (signal.SIGTERM, signal.SIGINT)

    def __init__(self) -> None:
        self.requested: str | None = None
        self._previous: dict[int, Any] = {}

    def _handle(self, signum: int, frame: Any) -> None:
        self.requested = signal.Signals(signum).name
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)

    def __enter__(self) -> _StopSignals:
        if threading.current_thread() is threading.main_thread():
            self._previous = {sig: signal.getsignal(sig) for sig in self.SIGNALS}
            for sig in self.SIGNALS:
                signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)


def _ignore_stop_signals(worker_id: int) -> None:
    """DataLoader workers leave a stop to the main process (a terminal's Ctrl-C and
    ``kill -- -PGID`` reach them too); they end when it shuts them down."""
    for sig in _StopSignals.SIGNALS:
        signal.signal(sig, signal.SIG_IGN)


def _barrier(world: int) -> None:
    if world > 1:
        dist.barrier()


def _check_resume(
    config: TrainConfig, run_dir: Path, resume: bool, preprocessing: Preprocessing
) -> TrainConfig | None:
    """The config to resume with (``config`` with the run's model sizes), or None to start
    afresh; raises MomaError on a mismatching or unexpected checkpoint, or when asked to
    resume a run that has none."""
    if resume:
        require_checkpoint(run_dir)
    elif has_checkpoint(run_dir):
        raise MomaError(
            f"run directory {str(run_dir)!r} already holds a checkpoint; pass --resume "
            "(resume=True in Python) to continue it or choose another directory"
        )
    else:
        return None
    saved, info = read_run_config(run_dir)
    if saved.model != config.model:
        raise MomaError(
            f"cannot resume: {str(run_dir)!r} holds model {saved.model!r}, "
            f"the config asks for {config.model!r}"
        )
    unused = get_model_entry(config.model).unused_config
    before, now = saved.model_config.to_dict(), config.model_config.to_dict()
    # The descriptor a run reads is the run's own (resumed as saved, like the sizes).
    unused = unused | {"descriptor_version"}
    differ = [
        f"{k} {before[k]!r} vs {now[k]!r}" for k in now if k not in unused and before[k] != now[k]
    ]
    if differ:
        raise MomaError(
            f"cannot resume: model sizes in {str(run_dir)!r} differ from the config "
            f"({', '.join(differ)})"
        )
    if _noise(saved) != _noise(config):
        raise MomaError(
            f"cannot resume: {str(run_dir)!r} was trained with sensor_noise "
            f"{_noise(saved) or 'off'}, the config asks for {_noise(config) or 'off'}"
        )
    saved_pre = run_preprocessing(info, run_dir)
    if saved_pre != preprocessing:
        raise MomaError(
            f"cannot resume: {str(run_dir)!r} was trained on clouds with "
            f"{saved_pre.describe()}, the training data has {preprocessing.describe()}"
        )
    return replace(config, model_config=saved.model_config)


def _noise(config: TrainConfig) -> str | None:
    """The sensor noise a run trains with, as text (None: clean frames)."""
    return f"on ({config.sensor_augmentation})" if config.sensor_noise else None


def _read_log(path: Path, max_step: int) -> list[dict[str, str]]:
    if not path.is_file():
        return []
    with path.open(newline="") as fh:
        return [r for r in csv.DictReader(fh) if int(r["step"]) <= max_step]


def _write_log(path: Path, rows: list[dict[str, Any]]) -> None:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=LOG_COLUMNS, extrasaction="ignore")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: r.get(k, "") for k in LOG_COLUMNS})
    atomic_write_text(path, buf.getvalue())


def plot_loss_curve(rows: list[dict[str, Any]], path: Path, title: str = "") -> None:
    """Training loss per logged step and validation loss per epoch, log scale, as PNG."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import FormatStrFormatter, NullFormatter

    # Constrained layout keeps the tick labels and the axis label inside the picture.
    fig = Figure(figsize=(6, 4), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    tr = [(int(r["step"]), float(r["loss"])) for r in rows if r["kind"] == "train"]
    va = [
        (int(r["step"]), float(r["val_loss"]))
        for r in rows
        if r["kind"] == "epoch" and r.get("val_loss") not in ("", None)
    ]
    ep = [(int(r["step"]), float(r["loss"])) for r in rows if r["kind"] == "epoch"]
    if tr:
        ax.plot(*zip(*tr, strict=True), lw=1, alpha=0.6, label="train (step)")
    if ep:
        ax.plot(*zip(*ep, strict=True), "o-", label="train (epoch mean)")
    if va:
        ax.plot(*zip(*va, strict=True), "s-", label="validation MSE")
    ax.set_xlabel("step")
    ax.set_ylabel("loss")
    if tr or va:
        ax.set_yscale("log")
        # Plain decimals; within one decade a log axis labels only its minor ticks (as
        # wide "4 x 10^-2" labels): label them then, and only then.
        ax.yaxis.set_major_formatter(FormatStrFormatter("%.3g"))
        low, high = ax.get_ylim()
        minor = FormatStrFormatter("%.3g") if high / low < 10 else NullFormatter()
        ax.yaxis.set_minor_formatter(minor)
        ax.legend()
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    atomic_write_bytes(path, buf.getvalue())


@torch.no_grad()
def validate(
    model: AffordanceModel, loader: DataLoader, progress: bool = False
) -> dict[str, float]:
    """Plain masked MSE over all real floor points and the map metrics of the episodes."""
    was_training = model.training
    model.eval()
    sq_sum, count = 0.0, 0
    preds, gts = [], []
    for batch in tqdm(loader, desc="validate", leave=False, disable=not progress):
        out = model(batch)
        mask = batch["floor_mask"]
        sq_sum += float(((out["pred"] - batch["floor_label"]).square() * mask).sum())
        count += int(mask.sum())
        p, g = episode_maps(batch, out["pred"])
        preds += p
        gts += g
    model.train(was_training)
    metrics = map_metrics(preds, gts)
    return {
        "val_loss": sq_sum / max(count, 1),
        "val_mae": metrics["mae"],
        "val_rmse": metrics["rmse"],
        "val_pcc": metrics["pcc"],
        "val_sim": metrics["sim"],
    }


def _initial_run(config: TrainConfig) -> tuple[Path, int, bool]:
    """The run directory whose weights start a fine-tuning (``config.init``), how many
    descriptor columns its model read and whether it lacked the reachability input that
    this run's reads; MomaError when it is missing or holds another model or another size
    (or a newer descriptor, or reads the reachability where this run does not)."""
    from momakitchen.train.checkpoint import read_run_config, resolve_run_dir

    src = resolve_run_dir(config.init)
    other, _ = read_run_config(src)
    # A run of an older descriptor starts a newer one (its weights widened, load_weights);
    # so does a run without the reachability input one with it.
    version = config.model_config.descriptor_version
    reach = config.model_config.reach_input
    widen_reach = reach and not other.model_config.reach_input
    # Which descriptor columns a model reads, and at how many target points it reads the
    # reachability, change no weight's shape.
    sizes = replace(
        other.model_config,
        descriptor_version=version,
        reach_input=other.model_config.reach_input or widen_reach,
        reach_points=config.model_config.reach_points,
        hidden_descriptor=config.model_config.hidden_descriptor,
    )
    if other.model != config.model or sizes != config.model_config:
        raise MomaError(
            f"TrainConfig.init {config.init!r} holds a {other.model!r} model of other sizes "
            f"than this {config.model!r} run's; fine-tuning needs the same model and sizes"
        )
    if other.model_config.descriptor_version > version:
        raise MomaError(
            f"TrainConfig.init {config.init!r} reads robot descriptor version "
            f"{other.model_config.descriptor_version}, newer than this run's {version}"
        )
    return src, other.model_config.descriptor_dim, widen_reach


def train(
    config: TrainConfig,
    train_set: Dataset,
    val_set: Dataset | None,
    out_dir: str | Path,
    resume: bool = False,
) -> TrainResult:
    """Train ``config.model`` on ``train_set``; validate on ``val_set`` after each epoch.

    Writes ``config.json``, ``model.safetensors``, the trainer state, ``log.csv`` and
    ``loss_curve.png`` into ``out_dir`` after every epoch (and every
    ``config.checkpoint_minutes`` within one). With ``resume=True`` a run directory that
    holds a checkpoint continues exactly where it was written (same model
    and sizes required; one without a checkpoint is refused); without it, a directory
    that holds one is refused. A SIGTERM or SIGINT (in the main thread) ends the run after
    the current step with a checkpoint there; the result's ``stopped_by`` names the signal.
    """
    if len(cast(Sized, train_set)) == 0:  # map-style datasets have a length
        raise MomaError("the training set is empty")
    run_dir = Path(out_dir)
    rank, world, created_group = _dist_setup()
    try:
        with _StopSignals() as stop:
            return _train(config, train_set, val_set, run_dir, resume, rank, world, stop)
    finally:
        if created_group:
            dist.destroy_process_group()


def _train(
    config: TrainConfig,
    train_set: Dataset,
    val_set: Dataset | None,
    run_dir: Path,
    resume: bool,
    rank: int,
    world: int,
    stop: _StopSignals,
) -> TrainResult:
    if config.num_threads:
        torch.set_num_threads(config.num_threads)
    elif world > 1:
        torch.set_num_threads(max(1, (os.cpu_count() or 1) // world))
    # The model learns the clouds of its training data: record how they were built.
    preprocessing = dataset_preprocessing(train_set) or Preprocessing()
    shards = dataset_shards(train_set)  # and which bytes it read
    resumed = _check_resume(config, run_dir, resume, preprocessing)
    resuming = resumed is not None
    if resumed is not None:
        config = resumed
    # Checked before the run directory is written: a bad option leaves nothing behind.
    if config.sensor_noise:
        if not hasattr(train_set, "use_sensor_noise"):
            raise MomaError("sensor_noise needs a generated dataset (its stored RGB-D frames)")
        cast(Any, train_set).use_sensor_noise(config.sensor_augmentation)
        reuse_freed_memory()  # before the workers fork: they rebuild each frame's clouds
    init = _initial_run(config) if config.init and not resuming else None
    if rank == 0:
        run_dir.mkdir(parents=True, exist_ok=True)
        if not resuming:
            views = dataset_view_distance(train_set)
            write_run_config(run_dir, config, preprocessing, shards, views)
    _barrier(world)

    torch.manual_seed(config.seed)
    model = build_model(config.model, config.model_config)
    optimizer_class = torch.optim.AdamW if config.decoupled_weight_decay else torch.optim.Adam
    optimizer = optimizer_class(
        model.parameters(), lr=config.lr, betas=config.betas, weight_decay=config.weight_decay
    )
    progress: dict[str, Any] = {"epoch": 0, "global_step": 0, "history": []}
    if resuming:
        load_weights(run_dir / WEIGHTS_FILE, model)
        progress = load_trainer_state(run_dir, optimizer)
        note = record_train_data(run_dir, shards, progress["global_step"]) if rank == 0 else None
        if note:
            print(f"momakitchen train: warning: {note}", file=sys.stderr)
    elif init is not None:
        load_weights(
            init[0] / WEIGHTS_FILE, model, descriptor_from=init[1], reach_from_none=init[2]
        )
    if world > 1 or not resuming:
        torch.manual_seed(config.seed * 7919 + 1 + rank + 131 * progress["epoch"])

    collate = PlanningCollator(
        EpisodeCollator(config.num_global, config.num_floor, config.seed), model.backbone
    )
    sampler: DistributedSampler[Any] = DistributedSampler(
        train_set, num_replicas=world, rank=rank, shuffle=True, seed=config.seed
    )
    resumable = _SkipSampler(sampler)
    loader = DataLoader(
        train_set,
        batch_size=config.batch_size,
        sampler=resumable,
        collate_fn=collate,
        num_workers=config.num_workers,
        worker_init_fn=_ignore_stop_signals if config.num_workers else None,
    )
    val_loader = None
    if val_set is not None and len(cast(Sized, val_set)) > 0 and rank == 0:
        val_loader = DataLoader(
            val_set,
            batch_size=config.batch_size,
            shuffle=False,
            collate_fn=collate,
            num_workers=config.num_workers,
            worker_init_fn=_ignore_stop_signals if config.num_workers else None,
        )
    steps_per_epoch = math.ceil(len(sampler) / config.batch_size)
    total_steps = config.epochs * steps_per_epoch
    if config.max_steps:
        total_steps = min(total_steps, config.max_steps)
    net: torch.nn.Module = DistributedDataParallel(model) if world > 1 else model

    log_path = run_dir / LOG_FILE
    rows: list[dict[str, Any]] = []
    if rank == 0:
        rows = _read_log(log_path, progress["global_step"]) if resuming else []
    step = progress["global_step"]
    history: list[dict[str, Any]] = list(progress["history"])
    show = config.progress and rank == 0

    # A checkpoint written within an epoch (checkpoint_minutes) records how far it got:
    # that epoch goes on from the next batch of the same shuffled order.
    done_in_epoch = int(progress.get("epoch_step", 0))
    # Making the loader's iterator draws its worker seed from the torch RNG, which the
    # uninterrupted run did at the epoch's start: restore the saved state after it.
    resume_rng = torch.get_rng_state() if done_in_epoch else None
    stopped = False
    for epoch in range(progress["epoch"], config.epochs):
        if step >= total_steps:
            break
        sampler.set_epoch(epoch)
        resumable.skip = done_in_epoch * config.batch_size
        if config.sensor_noise:
            cast(Any, train_set).set_epoch(epoch, config.seed)
        net.train()
        loss_sum = torch.zeros(3, dtype=torch.float64)  # loss*B, mse*B, samples
        seconds_before = float(progress["epoch_seconds"]) if done_in_epoch else 0.0
        if done_in_epoch and rank == 0:  # every rank's loss before the checkpoint
            loss_sum += torch.tensor(progress["epoch_loss_sum"], dtype=torch.float64)
        t0 = time.perf_counter()
        last_save = t0
        batches = iter(loader)
        if resume_rng is not None:
            torch.set_rng_state(resume_rng)
            resume_rng = None
        bar = tqdm(
            batches,
            desc=f"epoch {epoch + 1}/{config.epochs}",
            leave=False,
            disable=not show,
            initial=done_in_epoch,
            total=steps_per_epoch,
        )
        for batch in bar:
            if step >= total_steps:
                break
            lr = cosine_lr(config, step, total_steps)
            for group in optimizer.param_groups:
                group["lr"] = lr
            out = net(batch)
            optimizer.zero_grad(set_to_none=True)
            out["loss"].backward()
            if config.grad_clip:
                torch.nn.utils.clip_grad_norm_(model.parameters(), config.grad_clip)
            optimizer.step()
            step += 1
            b = batch["floor_xyz"].shape[0]
            loss_val = out["loss"].detach().item()
            loss_sum += torch.tensor([loss_val * b, out["mse"].item() * b, b])
            if show:
                bar.set_postfix(loss=f"{loss_val:.4f}")
            if rank == 0 and (step % config.log_every == 0 or step == 1):
                rows.append(
                    {
                        "kind": "train",
                        "epoch": epoch + 1,
                        "step": step,
                        "lr": f"{lr:.6g}",
                        "loss": f"{loss_val:.6g}",
                        "mse": f"{out['mse'].item():.6g}",
                    }
                )
                # Keep the CSV current during long epochs (resume trims rows past the
                # checkpoint's step).
                _write_log(log_path, rows)
            done_in_epoch += 1
            if done_in_epoch >= steps_per_epoch:
                continue  # the epoch's end writes its checkpoint
            timed = bool(config.checkpoint_minutes) and (
                time.perf_counter() - last_save >= 60 * config.checkpoint_minutes
            )
            due, stopped = _rank0_flags(world, timed, stop.requested is not None)
            if due or stopped:
                # Every rank's loss so far goes into the checkpoint (rank 0's share of a
                # resumed epoch), so the epoch's mean covers all of it.
                so_far = loss_sum.clone()
                if world > 1:
                    dist.all_reduce(so_far)
                if rank == 0:
                    within = {
                        "epoch_step": done_in_epoch,
                        "epoch_loss_sum": so_far.tolist(),
                        "epoch_seconds": seconds_before + time.perf_counter() - t0,
                    }
                    save_weights(run_dir / WEIGHTS_FILE, model)
                    save_trainer_state(
                        run_dir,
                        optimizer,
                        {"epoch": epoch, "global_step": step, "history": history, **within},
                    )
                    _write_log(log_path, rows)
                last_save = time.perf_counter()
                if stopped:
                    break
        if stopped:
            break
        done_in_epoch = 0
        seconds = seconds_before + time.perf_counter() - t0
        if world > 1:
            dist.all_reduce(loss_sum)
        n = max(float(loss_sum[2]), 1.0)
        record: dict[str, Any] = {
            "kind": "epoch",
            "epoch": epoch + 1,
            "step": step,
            "lr": cosine_lr(config, step, total_steps),
            "loss": float(loss_sum[0]) / n,
            "mse": float(loss_sum[1]) / n,
            "samples": int(loss_sum[2]),
            "samples_per_s": float(loss_sum[2]) / max(seconds, 1e-9),
            "seconds": seconds,
        }
        last = epoch + 1 == config.epochs or step >= total_steps
        stopped = _rank0_flags(world, stop.requested is not None)[0] and not last
        if rank == 0:
            if val_loader is not None and ((epoch + 1) % config.val_every == 0 or last):
                record.update(validate(model, val_loader, progress=show))
            history.append(record)
            rows.append({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in record.items()})
            if (epoch + 1) % config.checkpoint_every == 0 or last or stopped:
                save_weights(run_dir / WEIGHTS_FILE, model)
                save_trainer_state(
                    run_dir,
                    optimizer,
                    {"epoch": epoch + 1, "global_step": step, "history": history},
                )
                _write_log(log_path, rows)
                plot_loss_curve(
                    rows, run_dir / CURVE_FILE, title=f"{config.model} ({config.preset})"
                )
            if show:
                msg = ", ".join(f"{k} {v:.4g}" for k, v in record.items() if isinstance(v, float))
                tqdm.write(f"epoch {epoch + 1}: {msg}")
        _barrier(world)
        if stopped:
            break
    model.eval()
    return TrainResult(run_dir, model, history, step, stop.requested if stopped else None)
