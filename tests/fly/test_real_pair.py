"""The similarity measures on a real stereo pair (Middlebury 2014 motorcycle, scikit-image):
on the images as they come, ZNCC holds its accuracy when the right camera's exposure differs
and the zero-mean SSD does not; with the default photometric matching the zero-mean SSD
holds it, and noise. Floors from measured runs (2000 flies, 20 generations, seed 0; the full
figures are in tests/benchmarks/bench_real_pair.py and docs/engine.md)."""

import numpy as np
import pytest

from flylog.fly import Similarity
from flylog.fly.config import Photometric
from tests.benchmarks.bench_real_pair import condition, good_flies, motorcycle, run_flies


@pytest.fixture(scope="module")
def pair():
    return motorcycle()


def _share(pair, name, similarity, photometric=Photometric.NONE):
    left, right, truth = pair
    lit_left, lit_right = condition(left, right, name, np.random.default_rng(7))
    xyz, fitness = run_flies(
        lit_left,
        lit_right,
        similarity,
        flies=2000,
        generations=20,
        subpixel=False,
        photometric=photometric,
    )
    return good_flies(xyz, fitness, truth)[2].mean()


def test_zncc_keeps_its_accuracy_with_a_brighter_right_image(pair):
    # measured (seed 0): zncc 0.748 as is, 0.744 with the right image 25 % brighter;
    # zssd 0.656 as is, 0.334 brighter
    as_is = _share(pair, "as is", Similarity.ZNCC)
    brighter = _share(pair, "right +25 %", Similarity.ZNCC)
    assert as_is > 0.70
    assert brighter > 0.65
    zssd_brighter = _share(pair, "right +25 %", Similarity.ZSSD)
    assert zssd_brighter < 0.45
    assert brighter > zssd_brighter + 0.25


def test_matching_makes_the_zero_mean_ssd_hold_gain_and_noise(pair):
    # measured (seed 0), as is / right 25 % brighter / noise σ 5 / both: matched zssd 0.872 /
    # 0.841 / 0.799 / 0.751; zssd on the images as they come 0.656 / 0.334 / 0.258 / 0.095
    shares = [
        _share(pair, name, Similarity.ZSSD, Photometric.MATCHED)
        for name in ("as is", "right +25 %", "noise σ 5", "both")
    ]
    assert shares[0] > 0.82
    assert min(shares[1:]) > 0.70
    assert shares[3] > _share(pair, "both", Similarity.ZSSD) + 0.5
