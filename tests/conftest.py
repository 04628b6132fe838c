"""Shared test set-up: keep runs out of the working tree and progress bars off."""

import pytest


@pytest.fixture
def cli_runner():
    from click.testing import CliRunner

    return CliRunner()
