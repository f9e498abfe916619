from __future__ import annotations

from pathlib import Path

import pytest

from flylog.errors import ConfigError
from flylog.replay.config import Stereo
from flylog.sweep.spec import DEFAULT_VARIANT, Drive, load_spec, parse_seeds, with_overrides

from .conftest import LOGS, NEAR, write_spec

SCENES = LOGS.parent / "scenes"


def test_nested_tables_dotted_keys_counts_and_defaults(tmp_path: Path) -> None:
    spec = load_spec(
        write_spec(
            tmp_path,
            f"""
logs = ["{LOGS}/near-*.mcap", "{NEAR}"]
seeds = 3
[grid]
"engine.flies" = [100, 200]
[grid.planner]
tick_rate = [5, 10.5]
[[simulate]]
scene = "{SCENES}/corridor.toml"
duration = 1.5
resolution = [64, 48]
seeds = [4, 7]
drive = "planner"
""",
        )
    )
    assert spec.logs == (NEAR,)  # the glob and the path name one file: once
    assert spec.seeds == (0, 1, 2)
    assert spec.grid == (("engine.flies", (100, 200)), ("planner.tick_rate", (5.0, 10.5)))
    assert [v.name for v in spec.variants] == [DEFAULT_VARIANT]
    (sim,) = spec.simulate
    assert (sim.seeds, sim.drive, sim.duration, sim.resolution) == (
        (4, 7),
        Drive.PLANNER,
        1.5,
        (64, 48),
    )
    points = list(spec.grid_points())
    assert len(points) == 4 and points[-1] == (("engine.flies", 200), ("planner.tick_rate", 10.5))
    config = spec.config(spec.variants[0], points[1], 5)
    assert (config.engine.flies, config.planner.tick_rate, config.seed) == (100, 10.5, 5)


def test_variant_values_are_converted_and_the_grid_applies_last(tmp_path: Path) -> None:
    spec = load_spec(
        write_spec(
            tmp_path,
            f"""
logs = ["{NEAR}"]
[grid]
"engine.flies" = [300]
[[variants]]
name = "sgbm"
stereo = "sgbm"
engine = {{ flies = 50 }}
""",
        )
    )
    (variant,) = spec.variants
    assert dict(variant.overrides) == {"stereo": Stereo.SGBM, "engine.flies": 50}
    config = spec.config(variant, next(spec.grid_points()), 0)
    assert config.stereo is Stereo.SGBM and config.engine.flies == 300


def test_every_mistake_is_reported_at_once(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        """
logs = ["nothing/*.mcap"]
seeds = [0, -1]
colour = 3
[grid]
"engine.flies" = [100, "many"]
"engine.nope" = [1]
"seed" = [1, 2]
planner = { tick_rate = 5 }
[[variants]]
name = "a"
[[variants]]
name = "a"
[[simulate]]
scene = "missing.toml"
drive = "car"
resolution = [8, 8]
""",
    )
    with pytest.raises(ConfigError) as info:
        load_spec(path)
    lines = str(info.value).splitlines()
    expected = [
        "unknown field 'colour'",
        "'nothing/*.mcap' names no file",
        "missing.toml: no such file",
        "'simulate[0].drive': expected 'plan' or 'planner', got 'car'",
        "'simulate[0].resolution': expected [width, height], at least 16 px",
        "field 'seeds': expected a list of distinct seeds",
        "grid: field 'engine.flies': expected an integer, got 'many'",
        "grid: unknown key 'engine.nope': 'nope' is not a field of engine",
        "grid: key 'seed' is set by the spec's `seeds`",
        "grid: key 'planner.tick_rate': expected a non-empty list of values",
        "field 'variants[1].name': 'a' twice",
    ]
    assert len(lines) == len(expected)
    for line, fragment in zip(lines, expected, strict=True):
        assert fragment in line and line.startswith(str(tmp_path)), line


def test_cross_field_checks_name_the_variant_and_grid_point(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        f"""
logs = ["{NEAR}"]
[grid]
generations_per_frame = [1, 3]
[[variants]]
name = "baseline"
stereo = "sgbm"
""",
    )
    with pytest.raises(ConfigError) as info:
        load_spec(path)
    (line,) = str(info.value).splitlines()
    assert "variant 'baseline' with generations_per_frame = 3" in line
    assert "generations_per_frame must be 0 or 1, got 3" in line


def test_no_input_is_a_mistake(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no inputs"):
        load_spec(write_spec(tmp_path, "seeds = [0]\n"))


def test_seeds_from_the_command_line() -> None:
    assert parse_seeds("3") == (0, 1, 2)
    assert parse_seeds("5-9") == (5, 6, 7, 8, 9)
    assert parse_seeds("0,3, 10-12") == (0, 3, 10, 11, 12)
    for bad in ("0", "4-2", "a", "1,1", "-3", ""):
        with pytest.raises(ConfigError, match="--seeds: expected N"):
            parse_seeds(bad)


def test_one_spec_two_sides_of_an_ab_comparison(tmp_path: Path) -> None:
    """The same spec with the candidate's seeds and configuration: only those change."""
    spec = load_spec(write_spec(tmp_path, f'logs = ["{NEAR}"]\nseeds = 5\n'))
    config = tmp_path / "candidate.toml"
    config.write_text("[engine]\nflies = 1500\n", encoding="utf-8")
    side = with_overrides(spec, seeds=parse_seeds("5-9"), config=config)
    assert side.seeds == (5, 6, 7, 8, 9) and side.base.engine.flies == 1500
    assert (side.logs, side.variants, side.grid) == (spec.logs, spec.variants, spec.grid)
    assert with_overrides(spec) == spec
    sgbm = load_spec(
        write_spec(
            tmp_path, f'logs = ["{NEAR}"]\n[[variants]]\nname = "v"\nstereo = "sgbm"\n', "s.toml"
        )
    )
    config.write_text("generations_per_frame = 3\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="variant 'v'"):
        with_overrides(sgbm, config=config)


def test_cli_rejects_bad_seeds_and_configs(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from flylog.cli.main import cli

    spec = write_spec(tmp_path, f'logs = ["{NEAR}"]\n')
    out = tmp_path / "out"
    got = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(out), "--seeds", "3-1"])
    assert got.exit_code == 2 and "--seeds: expected N" in got.output
    got = CliRunner().invoke(
        cli, ["sweep", str(spec), "-o", str(out), "--config", str(tmp_path / "none.toml")]
    )
    assert got.exit_code == 2 and "none.toml" in got.output
    assert not out.exists()
