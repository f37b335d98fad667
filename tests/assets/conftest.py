"""Fixtures for the asset tests: a private URDF cache and a PyBullet DIRECT client."""

from __future__ import annotations

import pybullet as pb
import pytest


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("MOMAKITCHEN_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


@pytest.fixture
def client():
    c = pb.connect(pb.DIRECT)
    yield c
    pb.disconnect(c)
