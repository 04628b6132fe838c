"""Shared test set-up: keep runs out of the working tree and progress bars off."""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
os.environ.setdefault("EROSIM_REFERENCE", str(REPO.parent / "shared" / "reference"))


@pytest.fixture
def cli_runner():
    from click.testing import CliRunner

    return CliRunner()
