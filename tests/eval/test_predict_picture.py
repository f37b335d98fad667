"""scripts/predict_picture.py: the README's predict picture from a corrupted stored view."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"
SCRIPT = SCRIPTS / "predict_picture.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True)


def test_the_floor_fit_undoes_the_pitch_error_it_was_given(real_dataset, tmp_path):
    r = _run("--data", str(real_dataset), "--pitch", "2", "--out", str(tmp_path / "pred"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "pred" / "prediction.png").stat().st_size > 10_000
    correction = json.loads((tmp_path / "pred" / "prediction.json").read_text())["floor_correction"]
    # the real camera looks 2 deg higher than calibrated: the floor levels it back
    assert abs(correction["pitch_deg"] + 2.0) < 0.3, correction
    assert abs(correction["height_m"]) < 0.01, correction


def test_bad_input_is_one_line_and_status_2(tmp_path, real_dataset, monkeypatch, capsys):
    # In this process: the command itself runs in the test above.
    monkeypatch.syspath_prepend(str(SCRIPTS))
    from predict_picture import main
    from script_cli import run_main

    for args, message in [
        (["--data", str(tmp_path / "none")], "holds no scene shards"),
        (["--data", str(real_dataset), "--scene-id", "123456"], "scene 123456 is not in"),
        (["--data", str(real_dataset), "--sensor", "nosuch"], "nosuch"),
        (["--data", str(real_dataset), "--pitch", "45"], "pitch"),
    ]:
        monkeypatch.setattr(
            sys, "argv", ["predict_picture.py", *args, "--out", str(tmp_path / "x")]
        )
        with pytest.raises(SystemExit) as exit_:
            run_main(main, "predict_picture.py")
        err = capsys.readouterr().err
        assert exit_.value.code == 2, (args, err)
        assert message in err and len(err.strip().splitlines()) == 1, err
        assert err.startswith("predict_picture.py: error: "), err
    assert not (tmp_path / "x").exists()
