"""Fixtures of the package's tests: the command line of the same checkout, to compare with."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def command_line() -> str:
    """The `sdae-study` binary: $SDAE_STUDY_BIN, else built here in release mode."""
    binary = os.environ.get("SDAE_STUDY_BIN")
    if binary:
        return binary
    subprocess.run(
        ["cargo", "build", "--release", "-p", "sdae-cli", "--bin", "sdae-study"],
        cwd=ROOT,
        check=True,
    )
    return str(ROOT / "target" / "release" / "sdae-study")
