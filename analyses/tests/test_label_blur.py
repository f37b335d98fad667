"""analyses/label_blur.py: how far noise-aware training's labels move against the scene."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ANALYSES = Path(__file__).resolve().parents[1]


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(ANALYSES / "label_blur.py"), *args], capture_output=True, text=True
    )


def test_height_and_pitch_errors_leave_the_labels_and_roll_and_yaw_move_them(
    real_dataset, monkeypatch, tmp_path
):
    monkeypatch.syspath_prepend(str(ANALYSES))
    from label_blur import main

    out = tmp_path / "blur.json"
    main(["--data", str(real_dataset), "--split", "all", "--every", "2", "--draws", "2",
          "--json", str(out)])  # fmt: skip
    summary = json.loads(out.read_text())["summary"]
    for name in ("height +3 cm only", "pitch +3 deg only"):  # the floor fit undoes them
        assert summary[name]["shift_cm_median"] < 0.05, name
        assert summary[name]["blur_pcc_mean"] > 0.999, name
    for name in ("roll +3 deg only", "yaw +1 deg only"):  # no floor shows a turn
        assert summary[name]["shift_cm_median"] > 1.0, name
        assert summary[name]["blur_pcc_mean"] < summary["height +3 cm only"]["blur_pcc_mean"]
    # the mixes draw what training draws: some calibration error, hence some blur
    assert summary["default mix"]["shift_cm_median"] > 0.5
    assert summary["default mix"]["episodes"] == 2


def test_bad_input_is_one_line_and_status_2(tmp_path, real_dataset):
    for args, message in [
        (["--data", str(tmp_path / "none")], "does not exist"),
        (["--data", str(real_dataset), "--draws", "1"], "--draws >= 2"),
        (["--data", str(real_dataset), "--split", "train"], "no train episodes"),
    ]:
        r = _run(*args)
        assert r.returncode == 2, (args, r.stderr)
        assert message in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
