"""The benchmarks are not run by the test suite (timings belong to `make bench`), but the
files they read must exist: a moved fixture would otherwise only show in `make bench`."""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

import pytest

from tests import benchmarks

MODULES = sorted(
    m.name for m in pkgutil.iter_modules(benchmarks.__path__) if m.name.startswith("bench_")
)


@pytest.mark.parametrize("name", MODULES)
def test_every_path_a_benchmark_names_exists(name):
    module = importlib.import_module(f"tests.benchmarks.{name}")
    assert callable(module.run)
    for attr, value in vars(module).items():
        if isinstance(value, Path):
            assert value.exists(), f"{name}.{attr} = {value} does not exist"
