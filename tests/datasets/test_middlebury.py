import numpy as np
import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.datasets.middlebury import scene_rig
from flylog.datasets.run import import_dataset
from flylog.errors import LogError
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.metrics.image_truth import read_disparity_truth
from flylog.sources.inputs import log_rig
from tests.datasets.layouts import (
    BASELINE_MM,
    CX,
    CY,
    DOFFS,
    FOCAL,
    plane_pair,
    write_middlebury_scene,
)


def test_a_scene_folder_becomes_a_one_frame_log_with_its_calibration_and_truth(tmp_path):
    write_middlebury_scene(tmp_path / "plane")
    out = tmp_path / "plane.mcap"
    (log,) = import_dataset("middlebury", tmp_path / "plane", out)
    assert log.path == out and log.frames == 1
    reader = open_log(out)
    topics = reader.topics()
    assert {t: topics[t].count for t in topics} == {
        contract.LEFT_IMAGE: 1,
        contract.RIGHT_IMAGE: 1,
        contract.LEFT_CALIBRATION: 1,
        contract.RIGHT_CALIBRATION: 1,
        contract.TRUTH_DISPARITY: 1,
    }
    meta = reader.metadata()[contract.DATASET_METADATA]
    assert meta["format"] == "middlebury" and meta["mount"] == contract.MOUNT_NONE
    assert meta["scene"] == "plane" and meta["frames"] == "1"
    calib = {
        side: next(iter(reader.messages([t]))).value
        for side, t in contract.CALIBRATION_TOPICS.items()
    }
    np.testing.assert_array_equal(calib["left"].K, [[FOCAL, 0, CX], [0, FOCAL, CY], [0, 0, 1]])
    np.testing.assert_array_equal(calib["right"].K[0, 2], CX + DOFFS)
    assert calib["right"].P[0, 3] == pytest.approx(-FOCAL * BASELINE_MM / 1000)
    rig = log_rig(reader, mounted=False)
    assert rig == scene_rig(tmp_path / "plane")
    assert (rig.cx, rig.cy, rig.doffs, rig.baseline) == pytest.approx(
        (CX, CY, DOFFS, BASELINE_MM / 1000)
    )
    left, right, disparity = plane_pair()
    pair = next(reader.stereo_pairs())
    np.testing.assert_array_equal(pair.left, left)
    np.testing.assert_array_equal(pair.right, right)
    truth = read_disparity_truth(reader).images[0]
    np.testing.assert_array_equal(np.isnan(truth), np.isinf(disparity))
    np.testing.assert_array_equal(truth[np.isfinite(truth)], disparity[np.isfinite(disparity)])


def test_a_parent_folder_gives_one_log_per_scene_or_the_one_asked_for(tmp_path):
    for name in ("a", "b"):
        write_middlebury_scene(tmp_path / "all" / name, seed=ord(name))
    (tmp_path / "all" / "notes").mkdir()
    logs = import_dataset("middlebury", tmp_path / "all", tmp_path / "out")
    assert [p.path.name for p in logs] == ["a.mcap", "b.mcap"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["a.mcap", "b.mcap"]
    (one,) = import_dataset("middlebury", tmp_path / "all", tmp_path / "b.mcap", scene="b")
    assert open_log(one.path).metadata()[contract.DATASET_METADATA]["scene"] == "b"
    with pytest.raises(LogError, match="no scene 'c' \\(it holds a, b\\)"):
        import_dataset("middlebury", tmp_path / "all", tmp_path / "c.mcap", scene="c")
    assert not (tmp_path / "c.mcap").exists()


def test_a_folder_off_the_layout_exits_2_naming_the_missing_file_and_writes_nothing(tmp_path):
    write_middlebury_scene(tmp_path / "plane")
    (tmp_path / "plane" / "im1.png").unlink()
    out = tmp_path / "plane.mcap"
    result = CliRunner().invoke(
        cli, ["import", "middlebury", str(tmp_path / "plane"), "-o", str(out)]
    )
    assert result.exit_code == 2
    assert "im1.png missing" in result.output and "im0.png, im1.png, calib.txt" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plane"]


def test_an_inconsistent_calibration_is_refused_before_anything_is_written(tmp_path):
    write_middlebury_scene(tmp_path / "plane")
    calib = tmp_path / "plane" / "calib.txt"
    calib.write_text(calib.read_text().replace(f"doffs={DOFFS}", "doffs=9.0"))
    with pytest.raises(LogError, match="not rectified"):
        import_dataset("middlebury", tmp_path / "plane", tmp_path / "x.mcap")
    calib.write_text("cam0=[1 0 0; 0 1 0; 0 0 1]\n")
    with pytest.raises(LogError, match=r"calib\.txt: no 'cam1=' line"):
        import_dataset("middlebury", tmp_path / "plane", tmp_path / "x.mcap")
    assert not (tmp_path / "x.mcap").exists()


def test_the_cli_imports_and_says_what_it_wrote(tmp_path):
    write_middlebury_scene(tmp_path / "plane", truth=False)
    out = tmp_path / "p.mcap"
    result = CliRunner().invoke(
        cli, ["import", "middlebury", str(tmp_path / "plane"), "-o", str(out), "--limit", "1"]
    )
    assert result.exit_code == 0, result.output
    assert f"wrote {out} (1 stereo pair, " in result.output
    assert contract.TRUTH_DISPARITY not in open_log(out).topics()  # no disp0.pfm: no truth
