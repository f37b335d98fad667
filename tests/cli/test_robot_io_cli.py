"""The command-line forms of the robot inputs: predict --bag's option rules and serve's,
each a one-line error with exit status 2 and nothing written."""

from __future__ import annotations

import socket

import pytest

from momakitchen.cli.main import main

BAG = ["--depth-topic", "/d", "--camera-info-topic", "/i", "--target-mask-topic", "/m"]


def _error(capsys) -> str:
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        ([], "--depth is required (or read a frame with --bag)"),
        (["--depth", "d.npy", "--depth-topic", "/d"], "--depth-topic needs --bag"),
        (["--depth", "d.npy", "--every", "2"], "--every needs --bag"),
        (["--bag", "BAG", *BAG, "--every", "1", "--depth", "d.npy"], "--depth cannot be used"),
        (
            ["--bag", "BAG", *BAG, "--every", "1", "--intrinsics", "1", "1", "1", "1"],
            "--intrinsics cannot be used with --bag",
        ),
        (["--bag", "BAG", *BAG], "either --time SEC or --every N"),
        (["--bag", "BAG", *BAG, "--time", "1", "--every", "2"], "either --time SEC or --every N"),
        (
            ["--bag", "BAG", "--camera-info-topic", "/i", "--every", "1"],
            "--bag needs --depth-topic",
        ),
        (["--bag", "BAG", *BAG[:4], "--every", "1"], "--target-mask FILE or --target-mask-topic"),
        (
            ["--bag", "BAG", *BAG, "--target-mask", "m.png", "--every", "1"],
            "--target-mask FILE or --target-mask-topic",
        ),
        (["--bag", "NOTES", *BAG, "--every", "1"], "is neither a ROS 2 bag directory nor a .mcap"),
        (["--bag", "DB3", *BAG, "--every", "1"], "give the bag directory (with metadata.yaml)"),
        (["--bag", "MISSING", *BAG, "--every", "1"], "bag 'MISSING' does not exist"),
        (["--bag", "EMPTY", *BAG, "--every", "1"], "bag directory 'EMPTY' has no metadata.yaml"),
    ],
)
def test_predict_bag_option_rules(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "BAG").mkdir()
    (tmp_path / "EMPTY").mkdir()
    (tmp_path / "NOTES").write_text("x")
    (tmp_path / "DB3.db3").write_text("x")
    argv = [{"DB3": "DB3.db3"}.get(a, a) for a in argv]
    assert main(["predict", *argv, "--robot", "panda", "--out", "out"]) == 2
    assert message in _error(capsys)
    assert not (tmp_path / "out").exists()


def test_predict_bag_time_and_every_are_checked_by_the_parser(capsys):
    for option, value in (("--time", "-1"), ("--every", "0"), ("--max-dt", "0")):
        assert main(["predict", "--bag", "b", option, value, "--out", "o"]) == 2
        assert f"{option}: expected" in _error(capsys)


def test_serve_rejects_a_bad_port_and_a_busy_one(capsys):
    assert main(["serve", "--port", "70000"]) == 2
    assert "expected a port in [0, 65535], got '70000'" in _error(capsys)
    pytest.importorskip("aiohttp")
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["serve", "--host", "127.0.0.1", "--port", str(port)]) == 2
    assert f"cannot listen on 127.0.0.1:{port}" in _error(capsys)


def test_serve_names_a_missing_checkpoint(tmp_path, capsys):
    pytest.importorskip("aiohttp")
    assert main(["serve", "--checkpoint", str(tmp_path / "nope")]) == 2
    assert "checkpoint directory" in _error(capsys)


def test_the_documented_commands_parse():
    """Every `momakitchen ...` command of docs/ROBOT_IO.md is accepted by the parser."""
    import re
    import shlex
    from pathlib import Path

    from momakitchen.cli.main import build_parser

    doc = (Path(__file__).resolve().parents[2] / "docs" / "ROBOT_IO.md").read_text("utf-8")
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", doc, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = re.sub(r"\[[^\]]*\]", "", line.split("#")[0]).strip()
            if line.startswith("momakitchen "):
                commands.append(shlex.split(line)[1:])
    assert {argv[0] for argv in commands} == {"predict", "serve"}
    for argv in commands:
        args = build_parser(argv[0]).parse_args(argv)
        assert args.func is not None
