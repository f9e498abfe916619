"""The bundled scenes: found by name through importlib.resources, the same files as
fixtures/scenes (one copy)."""

from pathlib import Path

import pytest

from flylog.errors import ConfigError
from flylog.scene.bundled import bundled_names, resolve_scene, scenes_dir
from flylog.scene.load import load_scene

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"


def test_the_bundled_scenes_are_the_fixtures_directory() -> None:
    assert scenes_dir().resolve() == FIXTURES.resolve()
    assert {"corridor", "turn", "near-obstacle", "clutter", "doorways"} <= set(bundled_names())
    for name in bundled_names():
        load_scene(resolve_scene(name))


def test_a_name_is_a_bundled_scene_and_a_path_is_a_path(tmp_path: Path) -> None:
    assert resolve_scene("turn") == scenes_dir() / "turn.toml"
    mine = tmp_path / "turn"  # an existing file wins over the bundled name
    mine.write_text("")
    assert resolve_scene(mine) == mine
    assert resolve_scene("missing.toml") == Path("missing.toml")  # load_scene reports it
    with pytest.raises(ConfigError, match=r"nowhere: no such scene file, nor a bundled .*corridor"):
        resolve_scene("nowhere")
