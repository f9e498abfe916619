import numpy as np
import pytest

from flylog.datasets.pfm import read_pfm, write_pfm
from flylog.errors import LogError


@pytest.mark.parametrize("little", [True, False])
@pytest.mark.parametrize("shape", [(5, 7), (4, 3, 3)])
def test_pfm_round_trips_exactly_in_both_byte_orders(tmp_path, little, shape):
    values = np.random.default_rng(1).normal(size=shape).astype(np.float32)
    values.flat[3] = np.inf
    path = tmp_path / "d.pfm"
    write_pfm(path, values, little_endian=little)
    back = read_pfm(path)
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, values)


def test_pfm_rows_are_stored_bottom_to_top(tmp_path):
    path = tmp_path / "d.pfm"
    # a 2×3 big-endian file written by hand: the first row stored is the image's bottom one
    body = np.array([[4, 5, 6], [1, 2, 3]], dtype=">f4").tobytes()
    path.write_bytes(b"Pf\n3 2\n1.0\n" + body)
    np.testing.assert_array_equal(read_pfm(path), [[1, 2, 3], [4, 5, 6]])


def test_a_file_that_is_not_pfm_is_a_log_error_naming_it(tmp_path):
    path = tmp_path / "d.pfm"
    path.write_bytes(b"P6\n3 2\n255\n" + bytes(18))
    with pytest.raises(LogError, match=r"d\.pfm: not a PFM file"):
        read_pfm(path)
    path.write_bytes(b"Pf\n3 2\n-1.0\n" + bytes(8))
    with pytest.raises(LogError, match="holds only 8 bytes"):
        read_pfm(path)
