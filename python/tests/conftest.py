"""Shared fixtures: the repository's paths, the `mtcal` binary that `cargo test --workspace`
built, and the Rust reference program `python/refcheck`.

In CI (`MTCAL_REQUIRE_SHARED_DATA=1`, set by .ci/run) a missing binary or toolchain fails the
test instead of skipping it.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any, List, Optional

import pytest

PYTHON_DIR = Path(__file__).resolve().parents[1]
REPO = PYTHON_DIR.parent
EXAMPLES = REPO / "examples"
REQUIRED = os.environ.get("MTCAL_REQUIRE_SHARED_DATA") == "1"


def missing(why: str) -> None:
    """Skip, or fail in CI."""
    if REQUIRED:
        pytest.fail(f"{why} (MTCAL_REQUIRE_SHARED_DATA=1: a failure, not a skip)")
    pytest.skip(why)


@pytest.fixture(scope="session")
def mtcal_bin() -> Path:
    """The `mtcal` command line: $MTCAL_BIN, else debug/mtcal of the workspace's target folder
    ($CARGO_TARGET_DIR when cargo was told one, as the workspace's tests were built there)."""
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    path = Path(os.environ.get("MTCAL_BIN", target / "debug" / "mtcal"))
    if not path.is_file():
        missing(f"no mtcal binary at {path}: run `cargo build -p mtcal-xtask` (or cargo test --workspace) first")
    return path


def run_cli(mtcal_bin: Path, *args: Any, ok: tuple = (0,)) -> subprocess.CompletedProcess:
    """`mtcal ARGS…` from the repository root; its exit code must be one of `ok`."""
    done = subprocess.run(
        [str(mtcal_bin), *map(str, args)],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert done.returncode in ok, f"mtcal {args}: exit {done.returncode}\n{done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="session")
def refcheck() -> Any:
    """Runs python/refcheck (Rust, not through the binding): a request dict → its reply."""
    cargo = shutil.which("cargo")
    if cargo is None:
        missing("no cargo to build python/refcheck")
    manifest = PYTHON_DIR / "Cargo.toml"
    subprocess.run(
        [cargo, "build", "--quiet", "--release", "--manifest-path", str(manifest), "-p", "mtcal-refcheck"],
        check=True,
    )
    target = Path(os.environ.get("CARGO_TARGET_DIR", PYTHON_DIR / "target"))
    exe = target / "release" / "mtcal-refcheck"

    def call(request: dict) -> dict:
        done = subprocess.run(
            [str(exe)], input=json.dumps(request), capture_output=True, text=True, cwd=REPO, check=True
        )
        return json.loads(done.stdout)

    return call


def assert_same_json(a: Any, b: Any, rel: float = 1e-12, path: str = "$") -> None:
    """The same JSON tree: the same keys, lists and strings, every number within `rel`
    (relative; zero only equal to zero)."""
    if isinstance(a, dict):
        assert isinstance(b, dict), f"{path}: {type(b).__name__}, expected an object"
        assert sorted(a) == sorted(b), f"{path}: keys {sorted(a)} != {sorted(b)}"
        for k in a:
            assert_same_json(a[k], b[k], rel, f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), f"{path}: lists of {len(a)} and {len(b) if isinstance(b, list) else b!r}"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same_json(x, y, rel, f"{path}[{i}]")
    elif isinstance(a, bool) or a is None or isinstance(a, str):
        assert a == b, f"{path}: {a!r} != {b!r}"
    elif isinstance(a, (int, float)):
        assert isinstance(b, (int, float)) and not isinstance(b, bool), f"{path}: {b!r} is no number"
        assert math.isclose(a, b, rel_tol=rel, abs_tol=0.0) or a == b, f"{path}: {a!r} != {b!r}"
    else:
        raise AssertionError(f"{path}: unexpected {type(a).__name__}")


def count_numbers(a: Any) -> int:
    if isinstance(a, dict):
        return sum(count_numbers(v) for v in a.values())
    if isinstance(a, list):
        return sum(count_numbers(v) for v in a)
    return int(isinstance(a, (int, float)) and not isinstance(a, bool))
