"""The allocator setting of the processes flylog owns (the command, the sweep's workers): the
buffers of log reading are reused, not faulted in anew."""

from __future__ import annotations

import platform
import subprocess
import sys

import numpy as np
import pytest

from flylog.io import LogWriter, contract, encode
from flylog.process import keep_large_blocks

GLIBC = sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"

# Reads a log once to warm up, then twice more, as replay does (a reading thread); prints
# the minor page faults of the last two passes.
_READ = """
import resource, sys
if sys.argv[2] == "tuned":
    from flylog.process import keep_large_blocks
    assert keep_large_blocks()
from flylog.io import open_log
def read():
    for _ in open_log(sys.argv[1]).messages(read_ahead=8):
        pass
read()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
read()
read()
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(log, mode: str) -> int:
    done = subprocess.run(
        [sys.executable, "-c", _READ, str(log), mode], capture_output=True, text=True, check=True
    )
    return int(done.stdout.split()[-1])


@pytest.mark.skipif(not GLIBC, reason="mallopt is glibc's")
def test_reading_a_log_faults_far_fewer_pages(tmp_path):
    log = tmp_path / "frames.mcap"
    image = np.random.default_rng(0).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    with LogWriter(log) as out:  # 30 pairs of 640×480: 13 chunks of 4 MiB
        for k in range(30):
            t = k * 66_666_667
            frame = encode.raw_image(np.roll(image, k, axis=1), t, "camera_left")
            out.write(contract.LEFT_IMAGE, t, frame)
            out.write(contract.RIGHT_IMAGE, t, frame)
    # Best of three: how many chunk buffers are alive at once (images are views into their
    # chunk) depends on how far the reading thread runs ahead, i.e. on the machine's load.
    default = min(_faults(log, "default") for _ in range(3))
    tuned = min(_faults(log, "tuned") for _ in range(3))
    # measured: ~9 000 by default (glibc maps each chunk's buffer afresh); tuned 9 on a quiet
    # machine, ~6 800 under load (the reading thread runs further ahead: more chunks alive
    # at once than the heap held before, so it grows)
    assert tuned * 1.2 < default, (tuned, default)


def test_it_says_whether_it_applied():
    assert keep_large_blocks() is GLIBC
