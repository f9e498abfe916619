"""The compiled repeated-field writers against their numpy reference, byte for byte."""

import numpy as np
import pytest

from flylog.io import protobuf_wire as wire
from tests.io import wire_reference as ref


def _rows(n: int, k: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rows = rng.normal(size=(n, k))
    rows[rng.random((n, k)) < 0.3] = 0.0
    rows[rng.random((n, k)) < 0.05] = -0.0
    rows[rng.random((n, k)) < 0.05] = np.nan
    return rows


@pytest.mark.parametrize(("n", "k"), [(0, 2), (1, 1), (300, 2), (300, 4), (17, 14)])
def test_repeated_doubles_is_the_reference_byte_for_byte(n, k):
    rows = _rows(n, k, n + k)
    assert wire.repeated_doubles(3, rows) == ref.repeated_doubles(3, rows)
    assert wire.repeated_doubles(5, rows.T.copy().T) == ref.repeated_doubles(5, rows)


@pytest.mark.parametrize("n", [0, 1, 250])
def test_repeated_poses_is_the_reference_byte_for_byte(n):
    p, q = _rows(n, 3, n), _rows(n, 4, n + 1)
    assert wire.repeated_poses(3, p, q) == ref.repeated_poses(3, p, q)


def test_repeated_doubles_refuses_messages_longer_than_a_byte_counts():
    with pytest.raises(ValueError, match="at most 14"):
        wire.repeated_doubles(3, np.ones((2, 15)))
