"""The dataset card's example (docs/img/dataset_example.png): readable at a page's width,
the target outlined in the image and marked in both clouds, the cloud colours in a
legend."""

from __future__ import annotations

from dataset_helpers import make_dataset

from figure_helpers import assert_axes_labelled, assert_legible, legend_labels
from momakitchen.data.card import save_episode_figure
from momakitchen.data.shard import SceneShard, list_shards


def test_the_example_is_legible_and_marks_the_target(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    make_dataset(tmp_path / "ds", scenes=1)
    with SceneShard(next(iter(list_shards(tmp_path / "ds").values()))) as shard:
        keys = [(c, e) for c in shard.config_indices() for e in shard.episode_indices(c)]
        episodes = [shard.episode(c, e) for c, e in keys]
    # A view whose cloud holds target points (the synthetic views do not all see it).
    episode = next(ep for ep in episodes if (ep.global_align > 0).any())
    figures = []
    monkeypatch.setattr(plt, "close", lambda fig: figures.append(fig))
    save_episode_figure(episode, tmp_path / "example.png")
    (fig,) = figures
    assert_legible(fig)
    assert_axes_labelled(fig)
    clouds = fig.axes[2], fig.axes[3]
    for ax in clouds:
        assert [line for line in ax.lines if line.get_marker() == "*"], ax.get_title()
    labels = legend_labels(fig)
    assert {"cloud: target", "cloud: obstacle", "cloud: other"} <= set(labels)
    if (episode.semantic == 1).any():  # the target's pixels are outlined
        assert fig.axes[0].collections and "target" in [t.get_text() for t in fig.axes[0].texts]
