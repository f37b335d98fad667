"""Installing the external test package (tests/plugin_pkg) so that importlib.metadata
finds its entry points: a copy of its module plus a ``.dist-info`` with its
``entry_points.txt`` in a directory put on ``sys.path`` (what ``pip install --target``
writes, without the build), or a real ``pip install``."""

from __future__ import annotations

import shutil
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent / "plugin_pkg"
ENTRY_POINTS = """\
[momakitchen.models]
tinyaff = mk_testplugin.models:TinyAffordance
tinyaff-backbone = mk_testplugin.models:TinyBackbone
badshape = mk_testplugin.models:BadShape
broken = mk_testplugin.broken:Model
"""


def write_distribution(site: Path, name: str, entry_points: str, package: bool = True) -> Path:
    """A distribution ``name`` 0.1.0 in ``site`` with ``entry_points`` (the test package's
    module too, if ``package``)."""
    site.mkdir(parents=True, exist_ok=True)
    if package:
        shutil.copytree(PACKAGE / "src" / "mk_testplugin", site / "mk_testplugin")
    info = site / f"{name.replace('-', '_')}-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text(entry_points)
    return site


def pip_install(target: Path) -> Path:
    """``pip install`` the test package into ``target`` (offline, from a copy of its source
    so that the build leaves nothing in the repository)."""
    source = target.parent / "plugin_pkg_src"
    shutil.copytree(PACKAGE, source)
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-index",
            "--no-build-isolation",
            "--target",
            str(target),
            str(source),
        ],
        check=True,
        capture_output=True,
    )
    return target


@contextmanager
def on_path(site: Path) -> Iterator[None]:
    """``site`` on ``sys.path`` (its distributions' entry points visible) for the block; the
    test package's modules and every plug-in looked up are forgotten afterwards."""
    from momakitchen.models.registry import refresh_plugins

    sys.path.insert(0, str(site))
    refresh_plugins()
    try:
        yield
    finally:
        sys.path.remove(str(site))
        for mod in [
            m for m in sys.modules if m == "mk_testplugin" or m.startswith("mk_testplugin.")
        ]:
            del sys.modules[mod]
        refresh_plugins()
