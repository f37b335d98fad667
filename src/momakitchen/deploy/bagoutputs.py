"""The output directory of ``momakitchen predict --bag``, replaced whole or not at all.

Into ``OUT`` go each frame's ``prediction.json`` and ``prediction.png`` (at the top for a
single frame, else in ``frame_NNNNNN/``), ``frames.json`` (every frame's provenance and
poses, and the fused goal) and ``ros/``, a ROS 2 bag (MCAP) of the predictions
(:mod:`momakitchen.deploy.rosout`). Everything is written into a hidden sibling of
``OUT``, which takes ``OUT``'s place by renames once complete: a reader finds the previous
outputs or the new ones, never a mixture, and any failure (a full disk, a directory that
cannot be replaced) is a one-line MomaError naming the output, with the previous outputs
left as they were. So that replacing ``OUT`` loses nothing but earlier outputs, an
existing ``OUT`` may hold only what this command writes.
"""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from momakitchen.deploy.dirswap import stage_beside, swap_in
from momakitchen.errors import MomaError
from momakitchen.fileio import DISK_FULL, disk_full_message

if TYPE_CHECKING:
    from momakitchen.deploy.bagframes import BagFrame
    from momakitchen.deploy.fusion import MapFusion
    from momakitchen.deploy.rosout import PredictionBagWriter
    from momakitchen.models.inference import Prediction

# What predict --bag writes into OUT; an existing OUT may hold nothing else.
OUTPUT_ENTRY = re.compile(r"frames\.json|ros|prediction\.(json|png)|frame_\d{6}")


def check_replaceable(out: Path) -> None:
    """MomaError unless ``out`` is absent or a directory holding only earlier outputs of
    ``predict --bag`` (it is replaced whole, so anything else in it would be lost)."""
    if not out.is_dir():
        return
    foreign = sorted(p.name for p in out.iterdir() if not OUTPUT_ENTRY.fullmatch(p.name))
    if foreign:
        shown = ", ".join(foreign[:3]) + (
            f" and {len(foreign) - 3} more" if len(foreign) > 3 else ""
        )
        raise MomaError(
            f"output directory {str(out)!r} holds what predict --bag does not write "
            f"({shown}); it is replaced whole: give a new directory, or one with only earlier "
            "predict --bag outputs"
        )


class BagOutputs:
    """``predict --bag``'s outputs, frame by frame, then swapped into ``out``.

    A context manager: :meth:`add` each ``(frame, prediction)`` as it comes, then
    :meth:`finish`; leaving without :meth:`finish` (an error) removes what was written and
    leaves ``out`` untouched.

    Args:
        out: the output directory.
        single: one frame (``--time``): its files at the top of ``out``.
        odom_frame: fuse the frames' maps in this odometry frame (every frame needs its
            ``odom_pose``); the fused goal goes into ``frames.json`` and ``ros/``.
        pick_radius: the fused cells are ranked as ``predict`` ranks poses (m).
        cell: the fused map's cell size (m).
    """

    def __init__(
        self,
        out: Path,
        *,
        single: bool,
        odom_frame: str | None = None,
        pick_radius: float = 0.0,
        cell: float = 0.05,
        prefix: str = "/momakitchen",
    ) -> None:
        check_replaceable(out)
        self.out, self.single, self.prefix = out, single, prefix
        self.odom_frame, self.pick_radius = odom_frame, pick_radius
        self.frames: list[dict[str, Any]] = []
        self.fusion: MapFusion | None = None
        if odom_frame is not None:
            from momakitchen.deploy.fusion import MapFusion

            self.fusion = MapFusion(cell=cell)
        self._last_ns = 0
        self.leftover: Path | None = None  # the old outputs, if they could not be removed
        self._bag: PredictionBagWriter | None = None
        self.stage: Path | None = None

    @contextmanager
    def _named_as_final(self) -> Iterator[None]:
        """Errors name the outputs' final paths: the hidden sibling's name means nothing
        to the user."""
        stage = str(self.stage)
        try:
            yield
        except MomaError as exc:
            raise MomaError(str(exc).replace(stage, str(self.out))) from None
        except OSError as exc:
            where = str(exc.filename).replace(stage, str(self.out)) if exc.filename else self.out
            if exc.errno in DISK_FULL:
                raise MomaError(disk_full_message(where, exc)) from None
            raise MomaError(f"cannot write {str(where)!r}: {exc.strerror or exc}") from None

    def __enter__(self) -> BagOutputs:
        from momakitchen.deploy.rosout import PredictionBagWriter

        self.stage = stage_beside(self.out)
        try:
            bag = PredictionBagWriter(
                self.stage / "ros", self.prefix, fused=self.fusion is not None
            )
            with self._named_as_final():
                self._bag = bag.__enter__()
        except BaseException:
            shutil.rmtree(self.stage, ignore_errors=True)
            raise
        return self

    def add(self, frame: BagFrame, pred: Prediction) -> dict[str, Any]:
        """Write one frame's outputs; its ``frames.json`` entry."""
        from momakitchen.deploy.predict import write_outputs
        from momakitchen.deploy.rosout import StampedPrediction

        assert self.stage is not None and self._bag is not None, "use BagOutputs as a context"
        name = "." if self.single else f"frame_{frame.index:06d}"
        with self._named_as_final():
            write_outputs(
                pred,
                self.stage / name,
                frame.rgb,
                frame.depth,
                frame.intrinsics,
                frame.camera_to_base,
            )
            self._bag.write(StampedPrediction(frame.stamp_ns, frame.base_frame, pred))
        if self.fusion is not None:
            if frame.odom_pose is None:
                raise MomaError(f"depth frame {frame.index} has no odometry pose")
            self.fusion.add(pred, frame.odom_pose)
        self._last_ns = max(self._last_ns, frame.stamp_ns)
        poses = pred.to_dict(floor_points=False)["poses"]
        item = {**frame.summary(), "outputs": name, "poses": poses}
        self.frames.append(item)
        return item

    def _fused(self) -> dict[str, Any] | None:
        """Write the fused map and goal into the bag; their ``frames.json`` entry."""
        from momakitchen.deploy.rosout import StampedFusion

        if self.fusion is None:
            return None
        assert self.odom_frame is not None and self._bag is not None
        goal = self.fusion.goal(pick_radius=self.pick_radius)
        cells, value, std = self.fusion.fused()
        with self._named_as_final():
            self._bag.write_fused(
                StampedFusion(
                    self._last_ns,
                    self.odom_frame,
                    cells,
                    value,
                    std,
                    None if goal is None else goal.pose,
                )
            )
        target = self.fusion.target_xy
        return {
            "frame": self.odom_frame,
            "stamp": round(self._last_ns * 1e-9, 9),
            "looks": self.fusion.looks,
            "cell": self.fusion.cell,
            "cells": len(cells),
            "target_xy": None if target is None else [round(float(v), 6) for v in target],
            "goal": None
            if goal is None
            else {
                "x": round(goal.pose[0], 6),
                "y": round(goal.pose[1], 6),
                "yaw": round(goal.pose[2], 6),
                "affordance": round(goal.affordance, 6),
                "uncertainty": round(goal.uncertainty, 6),
            },
        }

    def finish(self, header: dict[str, Any]) -> dict[str, Any]:
        """Complete the bag and ``frames.json`` (``header``'s keys first) and swap the
        outputs into ``out``; the ``frames.json`` document."""
        from momakitchen.fileio import atomic_write_text

        assert self.stage is not None and self._bag is not None, "use BagOutputs as a context"
        fused = self._fused()
        bag, self._bag = self._bag, None
        with self._named_as_final():
            bag.__exit__(None, None, None)
            doc = {**header, "frames": sorted(self.frames, key=lambda f: f["index"])}
            if fused is not None:
                doc["fused"] = fused
            text = json.dumps(doc, indent=1, allow_nan=False) + "\n"
            atomic_write_text(self.stage / "frames.json", text)
        self.leftover = swap_in(self.stage, self.out)
        return doc

    def __exit__(self, exc_type: object, *exc: object) -> None:
        if self._bag is not None:
            self._bag.__exit__(exc_type or MomaError, None, None)  # abort: never completed
            self._bag = None
        if self.stage is not None:
            shutil.rmtree(self.stage, ignore_errors=True)  # gone after a swap; else discarded
