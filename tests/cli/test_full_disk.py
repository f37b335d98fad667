"""A full disk: one line naming what could not be written, exit 2, no temporary file and
no empty output directory left behind (the disk is made "full" by a writer that writes
part of its data and then fails with ENOSPC, as a real one does)."""

from __future__ import annotations

import errno
import os
import pathlib

from momakitchen.cli.main import main
from momakitchen.data import shard as shard_module


def _full(path, data: bytes) -> None:
    with open(path, "wb") as fh:
        fh.write(data[: len(data) // 2])
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "No space left on device" in err, err
    return err


def test_generate_on_a_full_disk(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(shard_module, "_write_durably", _full)
    out = tmp_path / "ds"
    argv = ["generate", "--out", str(out), "--scenes", "2", "--synthetic", "--quiet"]
    assert main(argv) == 2
    err = _one_line(capsys)
    assert "scene_000000.h5" in err and "run the same command again" in err
    assert not [p.name for p in (out / "scenes").iterdir()]  # no temporary shard
    # With space again, the same command finishes the dataset.
    monkeypatch.undo()
    assert main(argv) == 0
    assert main(["check", str(out)]) == 0


def test_a_full_disk_leaves_no_empty_output_directory(tmp_path, monkeypatch, capsys):
    """`scene` fails on its first write: no temporary file, no empty --out."""
    monkeypatch.setattr(pathlib.Path, "write_bytes", lambda self, data: _full(self, data))
    out = tmp_path / "nested" / "scene"
    argv = ["scene", "--scene-id", "7", "--no-render", "--out", str(out)]
    assert main(argv) == 2
    assert "scene.json" in _one_line(capsys)
    assert not out.exists() and not list((tmp_path / "nested").iterdir())


def test_a_full_disk_in_any_writer_is_one_line(tmp_path, monkeypatch, capsys):
    """An ENOSPC that no writer reported itself (a figure, a library) is still one line."""
    import momakitchen.cli.scene as scene_cli

    def failing(path, _text):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(scene_cli, "atomic_write_text", failing)
    out = tmp_path / "scene"
    assert main(["scene", "--scene-id", "7", "--no-render", "--out", str(out)]) == 2
    assert "scene.json" in _one_line(capsys)
    assert not out.exists()


def test_a_device_or_pipe_as_output_is_refused_not_replaced(tmp_path, capsys):
    """`--out /dev/full` used to replace the device with a regular file (the atomic
    rename); a FIFO stands in for it here."""
    fifo = tmp_path / "pipe.urdf"
    os.mkfifo(fifo)
    assert main(["robots", "export-urdf", "panda", "--out", str(fifo)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not a regular file" in err, err
    assert fifo.is_fifo()
