"""The package's layers: imports run one way, no cycles, no simulator where none is needed."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "momakitchen"
# Pipeline order: a package may import only from packages before it (and from itself).
# Evaluation comes last: the approach track renders new frames (generation) and scores
# what a robot runs (deploy's predict and map fusion), so it sits after both. The classical
# base placement methods answer what a model answers (a Prediction) from what it reads:
# after models, before deploy and eval, which call them beside the learned maps.
LAYERS = (
    "assets",
    "robots",
    "scene",
    "sim",
    "perception",
    "data",
    "models",
    "train",
    "generation",
    "placement",
    "deploy",
    "eval",
    "cli",
)
# Modules directly under momakitchen/ that import nothing of the package but each other.
LEAVES = ("errors", "fileio", "bullet", "frames", "metrics", "registry", "codec", "version")


def module_name(path: Path) -> str:
    parts = ["momakitchen", *path.relative_to(SRC).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> set[str]:
    """Every momakitchen module ``path`` imports, at the top or inside functions."""
    tree = ast.parse(path.read_text())
    pkg = module_name(path).rsplit(".", 0 if path.name == "__init__.py" else 1)[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join([*pkg.split(".")[: len(pkg.split(".")) - node.level + 1], base])
            for alias in node.names:  # `from momakitchen.x import y`: y may be a module
                candidate = f"{base}.{alias.name}"
                found.add(candidate if candidate in MODULES else base)
    return {m for m in found if m == "momakitchen" or m.startswith("momakitchen.")}


MODULES = {module_name(p): p for p in SRC.rglob("*.py")}
GRAPH = {name: imports(path) - {name} for name, path in MODULES.items()}


def part(module: str) -> str:
    """The layer or leaf a module belongs to (``""`` for the package root)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_every_module_belongs_to_a_layer_or_is_a_leaf():
    unknown = {m for m in MODULES if part(m) not in (*LAYERS, *LEAVES, "")}
    assert not unknown


def test_imports_follow_the_layers():
    against = []
    for module, targets in GRAPH.items():
        src = part(module)
        for target in targets:
            dst = part(target)
            if src == dst or dst in LEAVES or src == "":
                continue
            if src in LEAVES or dst == "" or LAYERS.index(dst) > LAYERS.index(src):
                against.append(f"{module} -> {target}")
    assert not against, against


# Evaluation by track: a track's package imports no other track (what they share lives in
# eval's shared modules, data/ or perception/); the report assembles them all.
TRACKS = ("approach", "robustness")
SHARED_EVAL = ("methods", "msr", "predictions", "stats", "evaluate")


def test_eval_tracks_import_no_other_track():
    against = []
    for module, targets in GRAPH.items():
        parts = module.split(".")
        if parts[1:2] != ["eval"] or len(parts) < 3 or parts[2] not in TRACKS:
            continue
        for target in targets:
            t = target.split(".")
            if t[1:2] == ["eval"] and len(t) > 2 and t[2] not in (parts[2], *SHARED_EVAL):
                against.append(f"{module} -> {target}")
    assert not against, against


def test_eval_is_by_track():
    tracks = {p.name for p in (SRC / "eval").iterdir() if (p / "__init__.py").exists()}
    assert tracks == {*TRACKS, "report"}
    # No module left of the flat prefix families, and no package re-exports its parts.
    flat = {p.stem for p in (SRC / "eval").glob("*.py")}
    assert not {m for m in flat if m.startswith(("approach_", "robustness_", "report_"))}
    for track in tracks:
        init = ast.parse((SRC / "eval" / track / "__init__.py").read_text())
        assert not [n for n in init.body if isinstance(n, (ast.Import, ast.ImportFrom))], track


def test_no_import_cycle():
    # Depth-first search for a back edge in the module graph.
    state: dict[str, int] = {}
    cycle: list[str] = []

    def visit(node: str, stack: list[str]) -> bool:
        state[node] = 1
        for nxt in sorted(GRAPH.get(node, ())):
            if nxt not in GRAPH:
                continue
            if state.get(nxt) == 1:
                cycle.extend(
                    [*stack[stack.index(nxt) :], node, nxt] if nxt in stack else [node, nxt]
                )
                return True
            if nxt not in state and visit(nxt, [*stack, node]):
                return True
        state[node] = 2
        return False

    assert not any(visit(m, []) for m in sorted(GRAPH) if m not in state), cycle


@pytest.mark.parametrize(
    "module",
    [
        "momakitchen",
        "momakitchen.data.torch_dataset",
        "momakitchen.models",
        "momakitchen.train",
        "momakitchen.deploy",
        "momakitchen.predict",
    ],
)
def test_no_simulator_where_none_is_needed(module):
    if module == "momakitchen.predict":
        code = "import momakitchen, sys; momakitchen.predict; "
    else:
        code = f"import {module}, sys; "
    code += "print('pybullet' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "False"


def test_the_simulator_package_loads_pybullet():
    # The check above can fail: the simulator's modules do import it.
    code = "import momakitchen.sim.world, sys; print('pybullet' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "True"
