"""The dataset card's example: the floor map in the colour map of every other affordance
figure, and the base-frame axes labelled as everywhere else (y positive to the left)."""

from __future__ import annotations

from dataset_helpers import make_dataset

from momakitchen.data.card import save_episode_figure
from momakitchen.data.shard import SceneShard, list_shards


def test_the_example_figure_speaks_as_the_others(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    make_dataset(tmp_path / "ds", scenes=1)
    with SceneShard(next(iter(list_shards(tmp_path / "ds").values()))) as shard:
        episode = shard.episode(0, 0)
    figures = []
    monkeypatch.setattr(plt, "close", lambda fig: figures.append(fig))
    save_episode_figure(episode, tmp_path / "example.png")
    (fig,) = figures
    clouds = fig.axes[2], fig.axes[3]
    for ax in clouds:
        assert ax.get_xlabel() == "y (m), positive to the left" and "right" not in ax.get_xlabel()
        fig.canvas.draw()
        ticks = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
        positions = [t.get_position()[0] for t in ax.get_xticklabels() if t.get_text()]
        assert all(float(s.replace("−", "-")) == -p for s, p in zip(ticks, positions, strict=True))
    floor = [c for c in clouds[1].collections if c.get_array() is not None]
    assert floor and floor[0].get_cmap().name == "viridis"
