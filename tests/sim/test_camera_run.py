"""The camera model inside `flylog simulate`: ideal bit for bit, seeds, metadata, errors."""

import json
from pathlib import Path

import pytest

from flylog.io import contract
from flylog.io.reader import open_log
from flylog.sim.camera_defects import CameraDefects
from tests.benchmarks.bench_camera_defects import without_defects
from tests.sim.cli_logs import image_messages, simulate_cli

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
CORRIDOR = FIXTURES / "scenes" / "corridor.toml"
# fixtures/regenerate.py's command of fixtures/logs/corridor.mcap, made by the renderer
# before the camera model existed (the fixture test holds it current).
FIXTURE_ARGS = ["--duration", "2", "--resolution", "160x120", "--seed", "0"]
SMALL = ["--duration", "0.4", "--resolution", "96x72"]


def _scene_with(tmp_path, table: str) -> Path:
    scene = tmp_path / "corridor.toml"
    scene.write_text(without_defects(CORRIDOR.read_text()) + "\n[camera_defects]\n" + table)
    return scene


@pytest.mark.parametrize("how", ["table", "option"])
def test_ideal_cameras_give_the_committed_fixtures_images_bit_for_bit(tmp_path, how):
    out = tmp_path / "ideal.mcap"
    if how == "table":
        result = simulate_cli(_scene_with(tmp_path, "ideal = true\n"), out, *FIXTURE_ARGS)
    else:  # the option overrides a realistic table
        scene = _scene_with(tmp_path, "ideal = false\n")
        result = simulate_cli(scene, out, *FIXTURE_ARGS, "--camera", "ideal")
    assert result.exit_code == 0, result.output
    want = image_messages(FIXTURES / "logs" / "corridor.mcap")
    assert len(want) == 62
    assert image_messages(out) == want


def test_realistic_cameras_same_seed_same_images_and_the_metadata_says_so(tmp_path):
    logs = {}
    for name, seed in (("a", "1"), ("b", "1"), ("c", "2")):
        logs[name] = tmp_path / f"{name}.mcap"
        result = simulate_cli(CORRIDOR, logs[name], *SMALL, "--seed", seed, "--camera", "realistic")
        assert result.exit_code == 0, result.output
    assert image_messages(logs["a"]) == image_messages(logs["b"])
    assert image_messages(logs["a"]) != image_messages(logs["c"])
    ideal = tmp_path / "ideal.mcap"
    assert simulate_cli(CORRIDOR, ideal, *SMALL, "--seed", "1", "--camera", "ideal").exit_code == 0
    bundled = tmp_path / "bundled.mcap"  # the bundled scene's own table: realistic
    assert simulate_cli(CORRIDOR, bundled, *SMALL, "--seed", "1").exit_code == 0
    assert image_messages(bundled) == image_messages(logs["a"])
    assert image_messages(ideal) != image_messages(logs["a"])
    meta = open_log(logs["a"]).metadata()[contract.SIMULATION_METADATA]
    defects = json.loads(meta["camera_defects"])
    assert defects["ideal"] is False and defects["read_noise_e"] == 2.5
    assert json.loads(open_log(ideal).metadata()[contract.SIMULATION_METADATA]["camera_defects"])[
        "ideal"
    ]


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ("ideal = false\ngamma = -1.0\n", "camera_defects.gamma"),
        ("ideal = false\nvignetting_corner = 0.0\n", "camera_defects.vignetting_corner"),
        ("ideal = false\nmotion_samples = 0\n", "camera_defects.motion_samples"),
        ("ideal = false\nread_noise = 2.0\n", "camera_defects.read_noise"),
        ("ideal = false\nshot_noise = 1\n", "camera_defects.shot_noise"),
        ("ideal = false\nexposure_ms = 80.0\n", "camera_defects.exposure_ms"),
    ],
)
def test_a_bad_camera_parameter_exits_2_naming_the_file_and_field(tmp_path, table, field):
    scene = _scene_with(tmp_path, table)
    out = tmp_path / "bad.mcap"
    result = simulate_cli(scene, out, *SMALL)
    assert result.exit_code == 2, result.output
    assert str(scene.name) in result.output and f"'{field}'" in result.output
    assert not out.exists()


def test_an_exposure_longer_than_the_frame_period_names_the_fix(tmp_path):
    scene = _scene_with(tmp_path, "ideal = false\nexposure_ms = 50.0\n")  # 15 Hz: 66.7 ms
    assert simulate_cli(scene, tmp_path / "ok.mcap", *SMALL).exit_code == 0
    result = simulate_cli(scene, tmp_path / "bad.mcap", *SMALL, "--frame-rate", "30")
    assert result.exit_code == 2
    assert "longer than the frame period (33.3333 ms at 30 Hz)" in " ".join(result.output.split())


def test_the_defect_studys_conditions_are_valid_tables_turning_on_their_group_only():
    from flylog.scene.load import parse_scene
    from tests.benchmarks.bench_camera_defects import CONDITIONS, GROUPS, NEUTRAL, defects_table

    typical = CameraDefects(ideal=False)
    for condition in CONDITIONS:
        text = without_defects(CORRIDOR.read_text()) + "\n" + defects_table(condition)
        defects = parse_scene(text, source=condition).spec.camera_defects
        assert defects.ideal == (condition == "ideal")
        if condition in GROUPS:
            for name, neutral in NEUTRAL.items():
                want = getattr(typical, name) if name in GROUPS[condition] else neutral
                assert getattr(defects, name) == want, (condition, name)
    assert (
        parse_scene(
            without_defects(CORRIDOR.read_text()) + "\n" + defects_table("all"), "all"
        ).spec.camera_defects
        == typical
    )
