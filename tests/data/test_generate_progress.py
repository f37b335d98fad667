"""The generation progress bar advances by configuration, not only by whole scene, in
one process and across workers; producers without the progress keyword still work."""

from __future__ import annotations

import re

from momakitchen.data.generator import GenerateRequest, generate_dataset, reports_progress
from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records

FOUR = SyntheticSceneConfig(configs_per_scene=4, episodes_per_config=1)
# 0.2 s per configuration: longer than the bar's minimum interval between redraws.
PACED = SyntheticSceneConfig(configs_per_scene=4, episodes_per_config=1, seconds_per_scene=0.8)


def _bar_states(err: str) -> list[str]:
    """The progress bar's successive "n/total scenes" readings."""
    return re.findall(r"(\d+\.\d)/(\d+) scenes", err)


def test_one_scene_advances_per_configuration(tmp_path, capsys):
    generate_dataset(
        GenerateRequest(out=tmp_path / "ds", num_scenes=1),
        synthetic_scene_records,
        PACED,
        write_card=False,
    )
    err = capsys.readouterr().err
    assert "generate (1 worker)" in err
    shown = [n for n, _ in _bar_states(err)]
    assert {"0.2", "0.5", "0.8", "1.0"} <= set(shown), shown
    assert "configurations=1]" in err and "configurations=3]" in err
    # episodes are shown once known (a written shard), never as a count of 0 before
    assert "episodes=0" not in err and "episodes written=4" in err


def test_workers_report_their_configurations(tmp_path, capsys):
    slow = SyntheticSceneConfig(configs_per_scene=4, episodes_per_config=1, seconds_per_scene=2.0)
    generate_dataset(
        GenerateRequest(out=tmp_path / "ds", num_scenes=2, workers=2),
        synthetic_scene_records,
        slow,
        write_card=False,
    )
    err = capsys.readouterr().err
    assert "generate (2 workers)" in err
    # Fractions of scenes appear before the first shard is written.
    first_whole = next(i for i, (n, _) in enumerate(_bar_states(err)) if float(n) >= 1.0)
    assert any(0 < float(n) < 1 for n, _ in _bar_states(err)[:first_whole]), err


def test_workers_are_never_more_than_scenes_left(tmp_path, capsys):
    generate_dataset(
        GenerateRequest(out=tmp_path / "ds", num_scenes=1, workers=4),
        synthetic_scene_records,
        FOUR,
        write_card=False,
    )
    assert "generate (1 worker)" in capsys.readouterr().err


def test_a_producer_without_progress_still_works(tmp_path):
    def plain(scene_id, config):
        return synthetic_scene_records(scene_id, config)

    assert reports_progress(synthetic_scene_records) and not reports_progress(plain)
    for root, producer in ((tmp_path / "a", plain), (tmp_path / "b", synthetic_scene_records)):
        request = GenerateRequest(out=root, num_scenes=2)
        generate_dataset(request, producer, FOUR, progress=False, write_card=False)
    for shard in sorted((tmp_path / "a" / "scenes").iterdir()):  # the same records
        assert shard.read_bytes() == (tmp_path / "b" / "scenes" / shard.name).read_bytes()
