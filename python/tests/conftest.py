"""Shared fixtures: a tiny simulated dataset with a model and its map (seconds), the `small`
preset with the shipped classifier (the command line's comparison), and the `endoloc` binary.

Everything is seeded: the same fixtures give the same frames, model and map on every run.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import endoloc

REPO = Path(__file__).resolve().parents[2]


def endoloc_binary() -> Path | None:
    """The `endoloc` command to compare with: $ENDOLOC_BIN, else the newest build in target/."""
    env = os.environ.get("ENDOLOC_BIN")
    if env:
        p = Path(env)
        if not p.is_file():
            pytest.fail(f"ENDOLOC_BIN={env} is not a file")
        return p
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    found = [p for p in (target / "release" / "endoloc", target / "debug" / "endoloc") if p.is_file()]
    return max(found, key=lambda p: p.stat().st_mtime) if found else None


@pytest.fixture(scope="session")
def cli():
    """Runs the `endoloc` binary; skips when there is none (set ENDOLOC_BIN or build it)."""
    binary = endoloc_binary()
    if binary is None:
        pytest.skip("no endoloc binary: build it (cargo build -p endoloc) or set ENDOLOC_BIN")

    def run(*args: str) -> str:
        r = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
        assert r.returncode == 0, f"endoloc {' '.join(map(str, args))} failed:\n{r.stderr}"
        return r.stdout + r.stderr

    run.binary = binary
    return run


@pytest.fixture(scope="session")
def tiny(tmp_path_factory):
    """A tiny dataset (80 + 30 frames at 160×120), a 6-zone model (1 epoch, 80×60 network input) and its map."""
    root = tmp_path_factory.mktemp("tiny")
    data, model = root / "data", root / "model"
    endoloc.simulate(
        preset="small", train_frames=80, test_frames=30, width=160, height=120, out=data
    )
    endoloc.train(data=data, zones=6, epochs=1, input="80x60", out=model)
    endoloc.map(model=model, data=data, threshold=20)
    return root


@pytest.fixture(scope="session")
def small(tmp_path_factory):
    """The `small` preset at 320×240 (300 training frames; 100 test frames, not 300, to keep
    the tests short), indexed with the shipped classifier (`builtin-joint`, no training) into
    50 zones, with its maps — as `endoloc demo` sets it up."""
    root = tmp_path_factory.mktemp("small")
    data, model = root / "data", root / "model"
    endoloc.simulate(preset="small", test_frames=100, out=data)
    endoloc.train(data=data, zones=50, out=model, pretrained="builtin-joint", epochs=0)
    endoloc.map(model=model, data=data)
    yield root
    shutil.rmtree(root, ignore_errors=True)
