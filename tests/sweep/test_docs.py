from __future__ import annotations

from pathlib import Path

from flylog.io.tables import schema_markdown
from flylog.sweep.results import HEAD_COLUMNS, TAIL_COLUMNS
from flylog.sweep.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]


def test_the_docs_tables_are_the_columns_written() -> None:
    text = (ROOT / "docs" / "sweep.md").read_text(encoding="utf-8")
    assert schema_markdown(HEAD_COLUMNS) in text
    assert schema_markdown(TAIL_COLUMNS) in text


def test_the_example_spec_is_valid_and_has_16_cells() -> None:
    spec = load_spec(ROOT / "fixtures" / "sweeps" / "example.toml")
    points = len(list(spec.grid_points()))
    assert len(spec.logs) * len(spec.variants) * points * len(spec.seeds) == 16


def test_the_gate_spec_has_10_cells_on_the_bundled_scenes() -> None:
    spec = load_spec(ROOT / "fixtures" / "sweeps" / "gate.toml")
    assert [s.scene.stem for s in spec.simulate] == ["corridor", "near-obstacle"]
    assert spec.seeds == (0, 1, 2, 3, 4) and not spec.logs
