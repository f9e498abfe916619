import numpy as np

from flylog.io import LogWriter, contract, encode, open_log


def test_empty_fly_cloud_round_trips(tmp_path):
    path = tmp_path / "empty.mcap"
    with LogWriter(path) as log:
        log.write(contract.FLIES, 0, encode.point_cloud(np.empty((0, 3)), np.empty(0), 0, "x"))
    (m,) = open_log(path).messages()
    assert m.value.xyz.shape == (0, 3) and m.value.fitness.shape == (0,)
