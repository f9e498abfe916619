"""Generated worlds: every family's worlds pass their checks, the checks hold on the
scene loaded back, and the same seed gives the same file."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flylog.errors import ConfigError
from flylog.scene.footprints import compile_footprints
from flylog.scene.generate import Family, GenerateConfig, generate_text
from flylog.scene.load import parse_scene
from flylog.scene.occupancy import clearance_grid, shortest_path, widest_gap
from flylog.scene.spec import ObstacleConfig, ObstacleKind

CONFIG = GenerateConfig()


def _reload(family: Family, seed: int):
    text = generate_text(family, seed, CONFIG)
    return text, parse_scene(text, source="generated")


def _path(scene, radius: float):
    fp = scene.footprints
    reach = fp.bounding_radius()
    lo = (np.min(fp.cx - reach) - 0.5, np.min(fp.cy - reach) - 0.5)
    hi = (np.max(fp.cx + reach) + 0.5, np.max(fp.cy + reach) + 0.5)
    grid = clearance_grid(fp, (*lo, *hi), 0.05)
    return shortest_path(grid, scene.spec.robot.start[:2], scene.goal, radius)


@pytest.mark.parametrize("family", list(Family))
def test_a_world_is_what_its_checks_say(family: Family) -> None:
    seed = 1
    text, scene = _reload(family, seed)
    g = scene.spec.generated
    assert g is not None and g.family == family.value and g.seed == seed
    found = _path(scene, g.check_radius)
    assert found.reachable is g.reachable is (family is not Family.DEAD_END)
    if g.reachable:
        assert g.optimal_path_m == pytest.approx(found.length, rel=0.02)  # grids differ
        assert g.narrowest_gap_m is not None and g.narrowest_gap_m >= 2 * g.check_radius
        straight = math.dist(scene.spec.robot.start[:2], scene.goal)
        assert straight <= found.length <= 3.0 * straight + 10.0
    else:
        assert g.optimal_path_m is None
        # not even a much smaller robot gets through: the way is walled shut, not narrow
        assert not _path(scene, 0.1).reachable
    assert generate_text(family, seed, CONFIG) == text


def test_worlds_vary_with_the_seed() -> None:
    a, b = (_reload(Family.CLUTTER, s)[1] for s in (0, 1))
    assert a.spec.ground != b.spec.ground
    assert a.obstacles != b.obstacles
    kinds = {ob.kind for scene in (a, b) for ob in scene.obstacles}
    assert kinds == set(ObstacleKind)


def test_passage_width_is_face_to_face() -> None:
    """A passage drawn at one width measures that width between its walls' faces."""
    config = GenerateConfig(passage_width=(1.2, 1.2), passages=(1, 1))
    scene = parse_scene(generate_text(Family.PASSAGES, 3, config), source="generated")
    assert scene.spec.generated is not None
    assert scene.spec.generated.narrowest_gap_m == pytest.approx(1.2, abs=0.11)


def test_clutter_gets_denser_with_the_difficulty() -> None:
    counts = []
    for d in (0.0, 1.0):
        text = generate_text(Family.CLUTTER, 1, GenerateConfig(difficulty=d))
        counts.append(len(parse_scene(text, source="generated").obstacles))
    assert counts[1] > counts[0] + 10


def test_widest_gap_is_the_bottleneck() -> None:
    """Two walls 1.0 m apart (faces) across the way: the widest path squeezes through a
    gap of 1.0 m; a robot wider than that has no path."""
    wall = dict(kind=ObstacleKind.WALL, thickness=0.1)
    obstacles = [
        ObstacleConfig(start=(2.0, 0.55), end=(2.0, 2.0), **wall),
        ObstacleConfig(start=(2.0, -2.0), end=(2.0, -0.55), **wall),
        ObstacleConfig(start=(-1.0, 2.0), end=(5.0, 2.0), **wall),
        ObstacleConfig(start=(-1.0, -2.0), end=(5.0, -2.0), **wall),
    ]
    grid = clearance_grid(compile_footprints(obstacles), (-1.0, -2.0, 5.0, 2.0), 0.05)
    assert widest_gap(grid, (0.0, 0.0), (4.0, 0.0)) == pytest.approx(1.0, abs=0.1)
    assert shortest_path(grid, (0.0, 0.0), (4.0, 0.0), 0.45).reachable
    assert not shortest_path(grid, (0.0, 0.0), (4.0, 0.0), 0.55).reachable
    straight = shortest_path(grid, (0.0, 0.0), (4.0, 0.0), 0.3)
    assert straight.length == pytest.approx(4.0, abs=0.05)
    assert np.allclose(straight.path[[0, -1]], [[0.0, 0.0], [4.0, 0.0]], atol=0.03)


def test_an_impossible_request_is_refused() -> None:
    with pytest.raises(ConfigError, match="passage_width"):
        GenerateConfig(passage_width=(0.6, 1.0))
    with pytest.raises(ConfigError, match="legs"):
        GenerateConfig(legs=(3, 2))


def test_cli_writes_a_world_and_a_range(tmp_path) -> None:
    from click.testing import CliRunner

    from flylog.cli.main import cli

    runner = CliRunner()
    one = tmp_path / "one.toml"
    result = runner.invoke(cli, ["scene", "generate", "dead-end", "--seed", "2", "-o", str(one)])
    assert result.exit_code == 0, result.output
    assert one.read_text() == generate_text(Family.DEAD_END, 2, CONFIG)
    folder = tmp_path / "worlds"
    result = runner.invoke(
        cli, ["scene", "generate", "passages", "--seeds", "4-5", "-o", str(folder)]
    )
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in folder.iterdir()) == ["passages-4.toml", "passages-5.toml"]
    bad = [
        "scene",
        "generate",
        "passages",
        "--passage-width",
        "0.5",
        "1.0",
        "-o",
        str(tmp_path / "x"),
    ]
    result = runner.invoke(cli, bad)
    assert result.exit_code == 2 and "passage_width" in result.output
    assert not (tmp_path / "x").exists()


def test_worlds_written_together_or_not_at_all(tmp_path, monkeypatch) -> None:
    """A range of worlds whose second file fails as it is published: a folder made for them
    is gone again, and a folder that was there keeps its files as they were."""
    import flylog.io.atomic as atomic
    from flylog.scene.generate import write_worlds

    real = atomic.publish
    calls = []

    def fail_second(tmp, path, batch=None):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        real(tmp, path, batch)

    monkeypatch.setattr(atomic, "publish", fail_second)
    new = tmp_path / "new"
    texts = {new / "a.toml": "a = 1\n", new / "b.toml": "b = 1\n"}
    with pytest.raises(OSError, match="No space"):
        write_worlds(texts, new)
    assert not new.exists()
    old = tmp_path / "old"
    old.mkdir()
    (old / "a.toml").write_text("earlier\n")
    calls.clear()
    with pytest.raises(OSError, match="No space"):
        write_worlds({old / "a.toml": "a = 1\n", old / "b.toml": "b = 1\n"}, old)
    assert {p.name: p.read_text() for p in old.iterdir()} == {"a.toml": "earlier\n"}
