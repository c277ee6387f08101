"""Shared fixtures: the repository root and the `brdf` command the values are compared with.

The command is `$BRDF_CLI` if set (`cargo xtask test` sets it to the `brdf` its Rust tests
ran), else `target/release/brdf` at the repository root (`cargo build --release -p brdf-cli`). A missing command fails the tests that
need it, with that instruction: they are never skipped.
"""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def root():
    return ROOT


@pytest.fixture(scope="session")
def cli():
    exe = pathlib.Path(os.environ.get("BRDF_CLI", ROOT / "target" / "release" / "brdf"))
    if not exe.is_file():
        pytest.fail(f"{exe} not found: run `cargo build --release -p brdf-cli` (or set BRDF_CLI)")

    def run(*args, check=True):
        p = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True)
        if check and p.returncode != 0:
            raise AssertionError(f"brdf {' '.join(map(str, args))} failed: {p.stderr}")
        return p

    return run
