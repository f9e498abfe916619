import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.fly.reference_sorting import median_numba, stable_argsort_numba


def test_known_order_ties_in_index_order_and_signed_zero():
    values = np.array([0.5, -1.0, 0.0, -0.0, 0.5, -np.inf, 1e300, -2.5])
    assert list(stable_argsort_numba(values)) == [5, 7, 1, 2, 3, 0, 4, 6]
    assert len(stable_argsort_numba(np.empty(0))) == 0
    assert median_numba(np.array([3.0, 1.0, 2.0])) == 2.0
    assert median_numba(np.array([4.0, 1.0, 2.0, 3.0])) == 2.5


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 500), st.sampled_from([0, 1, 3]))
def test_kernels_equal_numpy(seed, n, decimals):
    rng = np.random.default_rng(seed)
    # Rounded (many ties), signed, across magnitudes; or all equal but for one.
    values = np.round(rng.normal(size=n) * 10.0 ** rng.integers(-3, 4, n), decimals)
    np.testing.assert_array_equal(stable_argsort_numba(values), np.argsort(values, kind="stable"))
    assert median_numba(values) == np.median(values)
    flat = np.full(n, 7.0)
    flat[rng.integers(0, n)] = 1.0
    np.testing.assert_array_equal(stable_argsort_numba(flat), np.argsort(flat, kind="stable"))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 500), st.floats(0.0, 1.0))
def test_selection_kernels_equal_numpy(seed, n, share):
    from tests.fly.reference_sorting import select_in_place, smallest_stable_numba

    rng = np.random.default_rng(seed)
    values = np.round(rng.normal(size=n), 1)  # many ties, also at the cut
    k = min(n - 1, int(share * n))
    work = values.copy()
    assert select_in_place(work, k) == np.sort(values)[k]
    assert (work[:k] <= work[k]).all() and (work[k + 1 :] >= work[k]).all()
    np.testing.assert_array_equal(np.sort(work), np.sort(values))  # only reordered
    for keep in (0, k, k + 1, n, n + 3):
        np.testing.assert_array_equal(
            smallest_stable_numba(values, keep), np.argsort(values, kind="stable")[:keep]
        )


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 600), st.sampled_from(["ties", "spread", "odd"]))
def test_radix_selection_and_median_equal_numpy(seed, n, kind):
    from flylog.fly.sorting import median_radix, select_radix

    rng = np.random.default_rng(seed)
    if kind == "ties":  # many equal values, also at every rank
        values = np.round(rng.normal(size=n), 1)
    elif kind == "spread":  # both signs, exponents far apart: digits differ everywhere
        values = np.exp(rng.normal(0.0, 40.0, n)) * rng.choice([-1.0, 1.0], n)
    else:
        values = rng.choice([-1.0, 0.0, -0.0, 5e-324, 1e-300, 2.0, np.inf, -np.inf], n)
    before = values.copy()
    keys = np.empty(n, dtype=np.uint64)
    ordered = np.sort(values)
    for k in {0, n // 2, n - 1, int(rng.integers(0, n))}:
        assert select_radix(values, k, keys) == ordered[k]
    median = median_radix(values, keys)
    assert median == np.median(values) or (np.isnan(median) and np.isnan(np.median(values)))
    np.testing.assert_array_equal(values, before)  # not reordered


def test_radix_selection_of_all_equal_and_signed_zero():
    from flylog.fly.sorting import median_radix, select_radix

    keys = np.empty(1000, dtype=np.uint64)
    flat = np.full(1000, 0.25)
    assert select_radix(flat, 999, keys) == 0.25 and median_radix(flat, keys) == 0.25
    zeros = np.array([-0.0, 0.0, -0.0, -1.0])
    got = select_radix(zeros, 2, keys)
    assert got == 0.0 and not np.signbit(got)  # −0.0 comes back as 0.0
