"""Shared fixtures: the repository root, the command-line binary to compare
against, and a small Cornell box."""

import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]
CBOX = ROOT / "scenes" / "cornell-box.xml"


@pytest.fixture(scope="session")
def cli():
    """The `penumbra` binary: $PENUMBRA_BIN, else target/release/penumbra."""
    path = os.environ.get("PENUMBRA_BIN") or str(ROOT / "target" / "release" / "penumbra")
    if not os.access(path, os.X_OK):
        found = shutil.which("penumbra")
        if found is None:
            msg = "no penumbra binary (build it with cargo build --release, or set PENUMBRA_BIN)"
            if os.environ.get("CI"):
                pytest.fail(msg)
            pytest.skip(msg)
        path = found
    return path


@pytest.fixture
def cbox():
    return CBOX
