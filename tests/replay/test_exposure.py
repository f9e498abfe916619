"""The exposure watch: the two cameras' contrast ratio, and one warning for a measure that is
not gain-invariant."""

import warnings
from pathlib import Path

import numpy as np
import pytest

import flylog.replay.run as run_module
from flylog.config import from_mapping
from flylog.fly import EngineConfig, Similarity
from flylog.fly.config import Photometric
from flylog.replay.config import ReplayConfig
from flylog.replay.exposure import EVERY, WINDOW, ExposureWarning, ExposureWatch, contrast
from flylog.replay.run import replay
from flylog.sensors import StereoPair
from flylog.sources import input_at

NEAR = Path(__file__).resolve().parents[2] / "fixtures" / "logs" / "near-obstacle.mcap"


def _pair(rng, gain):
    left = rng.integers(40, 200, (240, 320, 3)).astype(np.uint8)
    right = np.clip(np.rint(left * gain + 7.0), 0, 255).astype(np.uint8)
    return left, right


def test_contrast_ratio_reads_a_gain_and_ignores_an_offset():
    rng = np.random.default_rng(0)
    left, right = _pair(rng, 1.25)
    assert contrast(right) / contrast(left) == pytest.approx(1.25, abs=0.01)
    shifted = (left.astype(np.int16) + 30).astype(np.uint8)
    assert contrast(shifted) == pytest.approx(contrast(left), rel=1e-6)
    assert contrast(left[..., 0]) > 0  # grey images too


def _watched(similarity, gain, pairs, photometric=Photometric.NONE):
    rng = np.random.default_rng(1)
    engine = EngineConfig(similarity=similarity, photometric=photometric)
    watch = ExposureWatch(engine, "the log x.mcap")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(pairs):
            watch.look(*_pair(rng, gain))
        watch.finish()
    return [w for w in caught if issubclass(w.category, ExposureWarning)]


def test_a_brighter_right_camera_under_zssd_warns_once_naming_the_setting():
    caught = _watched(Similarity.ZSSD, 1.25, 200)
    assert len(caught) == 1
    text = str(caught[0].message)
    assert "the log x.mcap" in text and "25% higher" in text
    assert "engine.similarity = zssd" in text and 'engine.photometric = "matched"' in text


@pytest.mark.parametrize("gain", [0.75, 1.25])
def test_either_way_warns(gain):
    assert len(_watched(Similarity.SAD, gain, EVERY * WINDOW)) == 1


def test_no_warning_for_equal_cameras_matched_ones_or_a_gain_invariant_measure():
    assert _watched(Similarity.ZSSD, 1.03, 200) == []
    assert _watched(Similarity.ZSSD, 1.25, 200, Photometric.MATCHED) == []
    for similarity in (Similarity.ZNCC, Similarity.GAIN_ZSSD, Similarity.CONTRAST_ZNCC):
        assert _watched(similarity, 1.25, 200) == []


def test_a_single_pair_is_judged_at_the_end():
    assert len(_watched(Similarity.ZSSD, 1.3, 1)) == 1


class _Brighter:
    """The near-obstacle log's replay source with its right images 30 % brighter."""

    def __init__(self, path):
        self._input = input_at(path)

    def replay_source(self, **kwargs):
        source = self._input.replay_source(**kwargs)
        records = source.records

        def brighter():
            for message in records:
                value = message.value
                if isinstance(value, StereoPair):
                    right = np.clip(value.right * 1.3, 0, 255).astype(np.uint8)
                    value = StereoPair(value.stamp_ns, value.left, right)
                    message = message._replace(value=value)
                yield message

        source.records = brighter()
        return source


@pytest.mark.parametrize(
    ("similarity", "photometric", "warns"),
    [("zssd", "none", 1), ("zssd", "matched", 0), ("contrast_zncc", "none", 0)],
)
def test_replay_of_a_log_with_a_brighter_right_camera(
    tmp_path, monkeypatch, similarity, photometric, warns
):
    monkeypatch.setattr(run_module, "input_at", _Brighter)
    engine = from_mapping(
        type(ReplayConfig().engine),
        {"flies": 400, "similarity": similarity, "photometric": photometric},
        source="test",
    )
    config = ReplayConfig(engine=engine, generations_per_frame=1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        replay(NEAR, tmp_path / "run.mcap", config)
    assert sum(issubclass(w.category, ExposureWarning) for w in caught) == warns
