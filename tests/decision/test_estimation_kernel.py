"""Eq. (4a)'s compiled loop against the NumPy version it replaces, bit for bit, and against a
hand computation."""

import numpy as np
import pytest

from nodnav.decision.estimation import PAIRWISE_BLOCK, _pairwise_sum, estimated_opinions, estimated_opinions_plain


@pytest.mark.parametrize("shape", [(24, 3, 11, 4), (6, 2, 5, 4), (2, 1, 1, 4), (120, 7, 9, 4), (3, 2, 16, 4),
                                   (2, 2, 26, 4), (1, 1, PAIRWISE_BLOCK + 1, 4), (2, 1, PAIRWISE_BLOCK + 2, 4),
                                   (4, 2, 11, 2), (2, 3, 7, 9)])
def test_the_compiled_integral_is_numpys_bit_for_bit(shape):
    rng = np.random.default_rng(sum(shape))
    g, n, m, d = shape
    observed = rng.normal(0.0, 1.0, (n, m, d)) * rng.uniform(0.0, 30.0, (n, m, d))
    planned = observed[None] + rng.normal(0.0, 1.0, (g, n, m, d)) * rng.uniform(0.0, 3.0, (g, n, m, d))
    planned[0, 0] = observed[0]  # a plan the robot follows exactly: zero deviation
    for dt, K1 in ((0.1, 5.0), (0.05, 1), (0.3, 0.7)):
        got, want = estimated_opinions(observed, planned, dt, K1), estimated_opinions_plain(observed, planned, dt, K1)
        # the same layout (later means over an axis sum in the order of the memory)
        assert got.shape == want.shape
        assert (got.flags.c_contiguous, got.flags.f_contiguous) == (want.flags.c_contiguous, want.flags.f_contiguous)
        assert got.tobytes() == want.tobytes()
    # strided inputs (a window's rows, a plan's columns) are read as they are
    got = estimated_opinions(observed[:, ::-1], planned[:, :, ::-1], 0.1)
    assert got.tobytes() == estimated_opinions_plain(observed[:, ::-1], planned[:, :, ::-1], 0.1).tobytes()


def test_a_constant_offset_integrates_to_its_square_times_the_window():
    """Positions off by (0.3, 0.4) m over a 1 s window, velocities exact: -K1 * 0.25 m^2 * 1 s."""
    observed = np.zeros((1, 11, 4))
    planned = np.zeros((2, 1, 11, 4))
    planned[1, 0, :, 0], planned[1, 0, :, 1] = 0.3, 0.4
    z = estimated_opinions(observed, planned, 0.1, K1=5.0)
    assert z[0, 0] == 0.0 and z[0, 1] == pytest.approx(-5.0 * 0.25 * 1.0, rel=1e-12)


def test_pairwise_sum_is_numpys_reduction():
    rng = np.random.default_rng(3)
    for n in (0, 1, 3, 7, 8, 9, 15, 16, 17, 64, 100, PAIRWISE_BLOCK):
        a = rng.normal(0.0, 1.0, n) * 10.0 ** rng.uniform(-8, 8, n)
        assert _pairwise_sum(a, n) == np.add.reduce(a) or n == 0
