"""The trainers' data helpers of :mod:`sloshrom.rom.losses`."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from sloshrom.rom.losses import cycle_slots, energy_cycles, pack_cycles, windows


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
    # the index form in NumPy (jnp would compile its gather for each shape)
    want = np.asarray(x)[np.asarray(starts)[:, None] + np.arange(length)]
    np.testing.assert_array_equal(got, want)


def _chirp_cycles():
    fs = 200.0
    t = np.arange(int(8 * fs)) / fs
    u = np.sin(2 * np.pi * (4 + 1.5 * t) * t) * (0.2 + 0.1 * t)  # 4-28 Hz: cycles of many lengths
    return energy_cycles(u, fs, (3.0, 40.0)), u


def test_packed_cycles_are_the_cycles_samples_one_after_the_other():
    cyc, u = _chirp_cycles()
    length = np.asarray(cyc.length)
    assert length.min() < length.max()  # lengths that differ: the packing is not trivial
    rng = np.random.default_rng(1)
    idx = rng.integers(0, cyc.n, (5, 6))
    slots = int(length[idx].sum(axis=1).max()) + 3
    p = pack_cycles(cyc, idx, slots)
    rows, weight = np.asarray(cyc.rows), np.asarray(cyc.weight)
    assert p.rows.shape == p.weight.shape == p.segment.shape == (5, slots) and p.k == 6
    for s in range(5):
        n_s = int(length[idx[s]].sum())
        want = np.concatenate([rows[c, :length[c]] for c in idx[s]])
        np.testing.assert_array_equal(p.rows[s, :n_s], want)
        np.testing.assert_array_equal(
            p.weight[s, :n_s], np.concatenate([weight[c, :length[c]] for c in idx[s]]))
        np.testing.assert_array_equal(p.segment[s, :n_s], np.repeat(np.arange(6), length[idx[s]]))
        # the free places: a segment of their own, no weight
        assert np.all(p.segment[s, n_s:] == 6) and np.all(p.weight[s, n_s:] == 0.0)
    # a signal's energy per cycle is the padded rows' sum to round-off
    x = rng.standard_normal(u.size)
    per = np.zeros((5, 7))
    np.add.at(per, (np.arange(5)[:, None], p.segment), x[p.rows] * p.weight)
    np.testing.assert_allclose(per[:, :6], np.sum(x[rows[idx]] * weight[idx], axis=-1),
                               rtol=1e-13, atol=1e-13 * np.abs(per).max())


def test_cycle_slots_hold_a_step_or_grow_to_it():
    cyc, _ = _chirp_cycles()
    length = np.sort(np.asarray(cyc.length))
    for k in (1, 4, 32):
        slots = cycle_slots(cyc, k)
        most = int(length[-k:].sum())
        assert slots <= most and (slots == most or slots % 128 == 0)
        assert slots >= k * length.mean()
    # the k longest cycles, drawn together, need every place: the packing grows, never
    # truncates a cycle
    idx = np.argsort(np.asarray(cyc.length))[-32:][None]
    p = pack_cycles(cyc, idx, 128)
    assert p.rows.shape[1] >= int(length[-32:].sum()) and p.rows.shape[1] % 128 == 0
    assert np.all(np.bincount(p.segment[0], minlength=33)[:32] == np.asarray(cyc.length)[idx[0]])
