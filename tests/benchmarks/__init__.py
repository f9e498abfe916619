"""Benchmarks (``make bench``): never part of ``make test``.

Each ``bench_*.py`` module here has ``run(out_dir: Path) -> list[dict]``; every dict is one
measured figure: ``{"name", "value", "unit", "reference"?, "ratio"?, "note"?}``. Speeds are
reported as a ratio against a reference measured in the same run wherever one exists.
"""
