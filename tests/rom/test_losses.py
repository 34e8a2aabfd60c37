"""The trainers' data helpers of :mod:`sloshrom.rom.losses`."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from sloshrom.rom.losses import windows


@pytest.mark.parametrize("trailing", [(), (3,)])
def test_windows_are_the_index_form_s_sub_sequences(trailing):
    # a record (the input) and a record of features per sample (the grey box's); the first
    # and the last start that keeps a window inside the record. Values are copied, not
    # computed: equal exactly on any machine
    rng = np.random.default_rng(3)
    n, length = 50, 7
    x = jnp.asarray(rng.standard_normal((n, *trailing)), jnp.float32)
    starts = jnp.asarray(np.concatenate([[0, n - length], rng.integers(0, n - length, 20)]))
    got = np.asarray(windows(x, starts, length))
    assert got.shape == (starts.size, length, *trailing)
    np.testing.assert_array_equal(got, np.asarray(x[starts[:, None] + jnp.arange(length)]))
