"""Shared fixtures of the minv Python tests.

Run against a build tree: PYTHONPATH=<build>/python /usr/bin/python3 -m pytest python/tests
(ctest's `python` test does this). MINV_SOURCE_DIR names the repository (README.md, plots/);
by default it is the folder above python/tests.
"""
import os
import pathlib

import pytest

import minv
from minv.reference import ScipyCholesky

SOURCE_DIR = pathlib.Path(os.environ.get("MINV_SOURCE_DIR",
                                         pathlib.Path(__file__).resolve().parents[2]))


def cli_path():
    """The `minv` command next to this module's build tree or install prefix, or None."""
    package = pathlib.Path(minv.__file__).resolve().parent
    for candidate in (os.environ.get("MINV_CLI"), package.parents[1] / "minv",
                      package.parents[3] / "bin" / "minv"):
        if candidate and pathlib.Path(candidate).is_file():
            return pathlib.Path(candidate)
    return None


@pytest.fixture
def scipy_cholesky():
    return ScipyCholesky


@pytest.fixture(scope="session")
def source_dir():
    return SOURCE_DIR
