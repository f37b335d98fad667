"""Every shipped recipe in scripts/recipes reads as the config of the command it is for:
`generate --config` (the sections of a generation config) or `train --config`."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import pytest

from momakitchen.cli.learn import train_config
from momakitchen.cli.main import build_parser
from momakitchen.codec import read_config_file
from momakitchen.data.config import GenerationConfig, preset_config
from momakitchen.errors import MomaError
from momakitchen.robots.user import register_user_robots, unregister_user_robot

RECIPE_DIR = Path(__file__).parents[1] / "scripts" / "recipes"


def needs_robots(path: Path) -> bool:
    """Whether the recipe's command registers the scaled arms (--robot-yaml
    scripts/recipes/robots): it is read with them registered, which takes a while."""
    return "recipes/robots" in path.read_text()


RECIPES = [
    pytest.param(p, marks=pytest.mark.slow) if needs_robots(p) else p
    for p in sorted(RECIPE_DIR.glob("*.yaml"))
]
SECTIONS = {f.name for f in fields(GenerationConfig)} - {"preset"}


@pytest.fixture(scope="module")
def recipe_robots():
    """The scaled arms some generate recipes name, registered as their commands'
    `--robot-yaml scripts/recipes/robots` does."""
    specs = register_user_robots(RECIPE_DIR / "robots")
    try:
        yield
    finally:
        for spec in specs:
            unregister_user_robot(spec.name)


def read_recipe(path: Path) -> object:
    """The config ``path`` makes: a GenerationConfig (on the hard preset, as the generate
    recipes are run) or the TrainConfig `momakitchen train --config path` builds."""
    data = read_config_file(path)
    if set(data) <= SECTIONS:
        return preset_config("hard", data, where=str(path))
    args = build_parser("train").parse_args(
        ["train", "--model", "navaff", "--config", str(path), "--data", "d", "--out", "o"]
    )
    return train_config(args)


def test_recipes_found() -> None:
    assert len(RECIPES) >= 10


@pytest.mark.parametrize("path", RECIPES, ids=lambda p: p.name)
def test_recipe_reads(path: Path, request: pytest.FixtureRequest) -> None:
    if needs_robots(path):
        request.getfixturevalue("recipe_robots")
    config = read_recipe(path)
    data = read_config_file(path)
    if "lr" in data:  # a training recipe's own values survive the preset's
        assert config.lr == pytest.approx(data["lr"])
    if "views" in data and "far_share" in data["views"]:
        assert config.views.far_share == data["views"]["far_share"]


def test_bad_recipe_named(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("preset: cpu\nlr: -1\n")
    with pytest.raises(MomaError, match="lr"):
        read_recipe(bad)
