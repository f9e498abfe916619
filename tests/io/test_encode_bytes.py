"""The numpy encoders (overlay, path) write, byte for byte, what the Foxglove SDK's objects
encode to."""

from __future__ import annotations

import foxglove.messages as fm
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flylog.io import LogWriter, contract, encode, open_log


def sdk_image_annotations(uv, colours, stamp_ns, thickness=3.0) -> bytes:
    """The SDK's encoding, the reference: one SDK object per point."""
    ts = encode.timestamp(stamp_ns)
    points = fm.PointsAnnotation(
        timestamp=ts,
        type=fm.PointsAnnotationType.Points,
        points=[fm.Point2(x=u, y=v) for u, v in np.asarray(uv, float).tolist()],
        outline_colors=[
            fm.Color(r=r, g=g, b=b, a=a) for r, g, b, a in np.asarray(colours, float).tolist()
        ],
        thickness=float(thickness),
    )
    return fm.ImageAnnotations(timestamp=ts, points=[points]).encode()


def sdk_poses_in_frame(poses, stamp_ns, frame_id) -> bytes:
    """The SDK's encoding of a path, the reference: one SDK Pose per pose."""
    poses = np.asarray(poses, float)
    half = poses[:, 2] / 2.0
    rows = zip(
        poses[:, 0].tolist(),
        poses[:, 1].tolist(),
        np.sin(half).tolist(),
        np.cos(half).tolist(),
        strict=True,
    )
    return fm.PosesInFrame(
        timestamp=encode.timestamp(stamp_ns),
        frame_id=frame_id,
        poses=[
            fm.Pose(
                position=fm.Vector3(x=x, y=y, z=0.0),
                orientation=fm.Quaternion(x=0.0, y=0.0, z=z, w=w),
            )
            for x, y, z, w in rows
        ],
    ).encode()


def overlay_colours(fitness: np.ndarray) -> np.ndarray:
    """As the replay colours its overlay: red (worst shown) to green (best), b = 0, a = 1."""
    a = (fitness - fitness.min()) / np.ptp(fitness) if len(fitness) > 1 else np.ones(len(fitness))
    return np.stack([1.0 - a, a, np.zeros(len(a)), np.ones(len(a))], axis=1)


@pytest.mark.parametrize("n", [0, 1, 1000])
@pytest.mark.parametrize("stamp_ns", [0, 7, 1_000_000_000, 123_456_789_012_345, 2**32 * 10**9 - 1])
def test_overlay_bytes_match_the_sdk(n, stamp_ns):
    rng = np.random.default_rng(n)
    uv = rng.uniform(-5.0, 640.0, (n, 2))
    colours = overlay_colours(rng.uniform(0.0, 1.0, n))
    got = encode.image_annotations(uv, colours, stamp_ns).encode()
    assert got == sdk_image_annotations(uv, colours, stamp_ns)


def test_zeros_negative_zeros_and_nan_are_encoded_as_the_sdk_does():
    # proto3 leaves out fields equal to zero (-0.0 included) but writes NaN
    uv = np.array([[0.0, 0.0], [-0.0, 1.5], [np.nan, -0.0], [3.0, np.inf]])
    colours = np.array([[0.0] * 4, [1.0, 0.0, 0.0, 1.0], [-0.0, 0.5, np.nan, 1.0], [1.0] * 4])
    for thickness in (3.0, 0.0, -0.0, 1e-300):
        got = encode.image_annotations(uv, colours, 5, thickness=thickness).encode()
        assert got == sdk_image_annotations(uv, colours, 5, thickness)


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(
        st.tuples(*[st.floats(allow_nan=True, allow_infinity=True, width=64)] * 6),
        max_size=20,
    ),
    stamp_ns=st.integers(0, 2**32 * 10**9 - 1),
)
def test_any_values_encode_as_the_sdk(values, stamp_ns):
    rows = np.array(values, dtype=float).reshape(-1, 6)
    uv, colours = rows[:, :2], rows[:, 2:]
    got = encode.image_annotations(uv, colours, stamp_ns).encode()
    assert got == sdk_image_annotations(uv, colours, stamp_ns)


def test_bad_shapes_and_times_are_refused_as_before():
    with pytest.raises(ValueError, match=r"uv \(N, 2\) and colours \(N, 4\)"):
        encode.image_annotations(np.zeros((3, 2)), np.zeros((2, 4)), 0)
    with pytest.raises(ValueError, match="must not be negative"):
        encode.image_annotations(np.zeros((1, 2)), np.zeros((1, 4)), -1)
    with pytest.raises(OverflowError):  # the SDK's Timestamp holds uint32 seconds
        encode.image_annotations(np.zeros((1, 2)), np.zeros((1, 4)), 2**32 * 10**9)


def test_the_writer_takes_it_and_the_reader_decodes_it(tmp_path):
    uv = np.array([[10.5, 20.25], [0.0, 479.0]])
    colours = np.array([[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0]])
    path = tmp_path / "overlay.mcap"
    with LogWriter(path) as log:
        log.write(contract.FLIES_OVERLAY, 42, encode.image_annotations(uv, colours, 42))
    (m,) = open_log(path).messages([contract.FLIES_OVERLAY])
    assert open_log(path).topics()[contract.FLIES_OVERLAY].schema == contract.IMAGE_ANNOTATIONS
    np.testing.assert_array_equal(m.value.uv, uv)
    np.testing.assert_array_equal(m.value.colours, colours)


@pytest.mark.parametrize("n", [0, 1, 400])
@pytest.mark.parametrize("frame_id", ["odom", "", "é"])
def test_path_bytes_match_the_sdk(n, frame_id):
    poses = np.random.default_rng(n).normal(0.0, 3.0, (n, 3))
    for stamp_ns in (0, 7, 123_456_789_012_345):
        got = encode.poses_in_frame(poses, stamp_ns, frame_id).encode()
        assert got == sdk_poses_in_frame(poses, stamp_ns, frame_id)


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(st.tuples(*[st.floats(allow_infinity=False, width=64)] * 3), max_size=20),
    stamp_ns=st.integers(0, 2**32 * 10**9 - 1),
)
def test_any_path_encodes_as_the_sdk(values, stamp_ns):
    poses = np.array(values, dtype=float).reshape(-1, 3)
    poses[::3, 2] = 0.0  # heading 0: the quaternion's z is left out
    got = encode.poses_in_frame(poses, stamp_ns, "odom").encode()
    assert got == sdk_poses_in_frame(poses, stamp_ns, "odom")


def test_path_refuses_what_it_refused():
    with pytest.raises(ValueError, match=r"poses must be \(N, 3\)"):
        encode.poses_in_frame(np.zeros((2, 2)), 0, "odom")
    with pytest.raises(ValueError, match="must not be negative"):
        encode.poses_in_frame(np.zeros((1, 3)), -5, "odom")
