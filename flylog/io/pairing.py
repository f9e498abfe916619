"""Pairing left and right images into stereo pairs while streaming, with bounded buffering."""

from __future__ import annotations

import warnings
from collections import deque
from collections.abc import Iterable, Iterator

from flylog.io import contract
from flylog.io.records import LogMessage
from flylog.sensors import StereoPair


class UnpairedImagesWarning(UserWarning):
    """Some images had no partner within the tolerance and were skipped."""


def pair_stereo(
    messages: Iterable[LogMessage], *, tolerance_ns: int = 5_000_000, max_pending: int = 8
) -> Iterator[LogMessage]:
    """Replace the left and right image messages of a log-time-ordered stream by
    ``STEREO_PAIRS`` messages carrying a StereoPair (stamped with the left image's log
    time), emitted as soon as the second image of a pair arrives; other messages pass
    through unchanged.

    Images pair when their log times differ by at most ``tolerance_ns``. An image older
    than the other side's oldest waiting image can never pair (both sides are in time
    order) and is skipped; at most ``max_pending`` images wait on a side whose partner
    stream is silent. Skipped images are counted in one UnpairedImagesWarning at the end.
    """
    pending: dict[str, deque[LogMessage]] = {
        contract.LEFT_IMAGE: deque(),
        contract.RIGHT_IMAGE: deque(),
    }
    left, right = pending[contract.LEFT_IMAGE], pending[contract.RIGHT_IMAGE]
    skipped = 0
    for m in messages:
        side = pending.get(m.topic)
        if side is None:
            yield m
            continue
        side.append(m)
        while left and right:
            dt = left[0].log_time_ns - right[0].log_time_ns
            if abs(dt) <= tolerance_ns:
                lm, rm = left.popleft(), right.popleft()
                pair = StereoPair(lm.log_time_ns, lm.value, rm.value)
                yield LogMessage(contract.STEREO_PAIRS, lm.log_time_ns, contract.STEREO_PAIR, pair)
            else:
                (left if dt < 0 else right).popleft()
                skipped += 1
        if len(side) > max_pending:
            side.popleft()
            skipped += 1
    skipped += len(left) + len(right)
    if skipped:
        msg = f"{skipped} images had no partner within {tolerance_ns} ns and were skipped"
        warnings.warn(msg, UnpairedImagesWarning, stacklevel=2)
