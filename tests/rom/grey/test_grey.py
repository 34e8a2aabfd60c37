"""The grey-box ROM: its column's physics (limits, invariants, its two implementations), its
identification (a column recovers its own parameters) and its estimator (strictly proper, the
step contract, files)."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import compiled_programs, perturbation_tolerance
from sloshrom.config import G, Tank
from sloshrom.rom import GreyBox, load_model
from sloshrom.rom.errors import ROMError
from sloshrom.rom.grey.network import GreySpec
from sloshrom.rom.grey.physics import (
    LANES_FROM,
    _causal_batch,
    _causal_lanes,
    causal_intervals,
    design_rows,
    filter_normal_equations,
    filter_output,
    grey_features,
    physical_parameters,
    physics_rest,
    physics_step,
)
from sloshrom.rom.grey.training import PHYSICS_BOUNDS, fit_physics
from sloshrom.rom.registry import CLASSES

FS = 500.0
TANK = Tank(fill=0.5)
#: the virtual rig's calibrated physics, as the column's variables (beta, restitution, contact
#: Hz, gap factor, ln gate rate, gate relaxation s, coherence g)
RIG_LIKE = (0.8, 0.15, 200.0, 1.0, math.log(11.9), 0.00988, 7.16)
N_BALLS, N_SUB, N_PAST = 10, 8, 6


def _phys(*x: float) -> np.ndarray:
    return physical_parameters(*x, liquid_mass=TANK.liquid_mass, ullage=TANK.ullage)


def _harmonic(f_hz: float, accel_g: float, seconds: float = 3.0) -> np.ndarray:
    """Tank velocity (m/s) of a ramped harmonic motion of acceleration amplitude ``accel_g``."""
    t = np.arange(int(seconds * FS)) / FS
    ramp = np.minimum(1.0, t / 0.5)
    om = 2 * np.pi * f_hz
    return ramp * accel_g * G / om * np.sin(om * t)


def _unit_taps() -> np.ndarray:
    """The filter that outputs the mean force of the interval ending at the sample."""
    taps = np.zeros((N_PAST + 1) * N_SUB)
    taps[N_SUB:2 * N_SUB] = 1.0 / N_SUB
    return taps


def test_no_force_below_one_g():
    """Below 1 g the liquid is never pulled off the floor: no release, no force (the physics'
    limit, as the rig's)."""
    u = _harmonic(12.0, 0.9)
    o = causal_intervals(_phys(*RIG_LIKE)[None], u[None], FS, N_BALLS, N_SUB)
    assert np.all(o == 0.0)
    u = _harmonic(12.0, 3.0)
    o = causal_intervals(_phys(*RIG_LIKE)[None], u[None], FS, N_BALLS, N_SUB)
    assert np.max(np.abs(o)) > 1.0  # impacts of several N above 1 g


def test_search_of_a_record_below_one_g_finds_no_force():
    """A record that never lifts the liquid: every candidate column gives no force, its filter
    zero taps (not a singular least-squares system inside the search)."""
    rng = np.random.default_rng(5)
    u = _harmonic(12.0, 0.6, seconds=6.0)
    y = 0.01 * rng.standard_normal(u.size)
    spec = GreySpec(2, 4, 10, N_BALLS, N_SUB, N_PAST)
    physics, taps, history = fit_physics(u, y, FS, spec, TANK.liquid_mass, TANK.ullage,
                                         generations=1, population=2, windows=2)
    assert np.all(taps == 0.0)
    assert np.all(np.isfinite(physics)) and np.isfinite(history["objective"])


def test_search_in_threads_is_the_search_in_order(monkeypatch):
    """The candidates of a generation scored side by side, one a thread (the column's kernel
    on one numba thread each), give the search of one core to the bit: the same parameters,
    taps and objective."""
    import sloshrom.rom.grey.training as gt

    u = _harmonic(12.0, 4.0, seconds=6.0)
    y = grey_features(_phys(*RIG_LIKE), _unit_taps(), u, FS, N_BALLS, N_SUB, N_PAST)[0, :, 0]
    spec = GreySpec(2, 4, 10, N_BALLS, N_SUB, N_PAST)
    args = (u, y, FS, spec, TANK.liquid_mass, TANK.ullage)
    kw = {"generations": 2, "population": 3, "windows": 3}
    used = []
    pool_class = gt.ThreadPoolExecutor

    def counted(n, **k):
        used.append(n)
        return pool_class(n, **k)

    monkeypatch.setattr(gt, "usable_cores", lambda: [0, 1, 2])
    monkeypatch.setattr(gt.numba, "get_num_threads", lambda: 2)  # (numba's own: the cores)
    monkeypatch.setattr(gt, "ThreadPoolExecutor", counted)
    threaded = fit_physics(*args, **kw)
    assert used == [2]  # the pool was used, as many threads as numba allows
    monkeypatch.setattr(gt, "usable_cores", lambda: [0])
    alone = fit_physics(*args, **kw)
    assert used == [2]  # one core: no pool
    np.testing.assert_array_equal(threaded[0], alone[0])
    np.testing.assert_array_equal(threaded[1], alone[1])
    assert threaded[2]["objective"] == alone[2]["objective"]
    assert threaded[2]["evaluations"] == alone[2]["evaluations"]
    assert np.max(np.abs(threaded[1])) > 0  # a column that makes a force: a real search


def _search_case(seconds: float = 8.0) -> tuple[tuple[object, ...], dict[str, int]]:
    u = _harmonic(12.0, 4.0, seconds=seconds)
    y = grey_features(_phys(*RIG_LIKE), _unit_taps(), u, FS, N_BALLS, N_SUB, N_PAST)[0, :, 0]
    spec = GreySpec(2, 4, 10, N_BALLS, N_SUB, N_PAST)
    return (u, y, FS, spec, TANK.liquid_mass, TANK.ullage), {"generations": 6, "population": 3,
                                                            "windows": 3}


def test_search_with_trials_scored_in_part_is_the_search_in_full():
    """A trial whose filter error alone exceeds its target's score is returned that error
    (differential evolution discards it either way): the same search to the bit as scoring
    every trial in full, with some trials really cut short."""
    args, kw = _search_case()
    cut = fit_physics(*args, **kw)
    full = fit_physics(*args, **kw, prune=False)
    np.testing.assert_array_equal(cut[0], full[0])
    np.testing.assert_array_equal(cut[1], full[1])
    assert cut[2]["objective"] == full[2]["objective"]
    assert cut[2]["evaluations"] == full[2]["evaluations"]
    assert full[2]["pruned"] == 0
    assert 0 < cut[2]["pruned"] < cut[2]["evaluations"]
    assert np.max(np.abs(full[1])) > 0  # a column that makes a force: a real search


def test_search_scores_in_full_once_a_trial_scored_in_part_is_kept(monkeypatch, caplog):
    """Targets that are not the trials' competitors (here below every score: every trial of
    the first generation is cut short, and the improving ones are kept) are caught after that
    generation, said once, and the search goes on scoring every trial in full."""
    import logging

    import sloshrom.rom.grey.training as gt

    args, kw = _search_case()
    monkeypatch.setattr(gt, "_best_first", lambda e: np.full_like(e, -1.0))
    with caplog.at_level(logging.WARNING, logger="sloshrom"):
        _, _, history = fit_physics(*args, **kw)
    lines = [r.getMessage() for r in caplog.records if "scored in part was kept" in r.getMessage()]
    assert len(lines) == 1
    members = kw["population"] * len(PHYSICS_BOUNDS)
    assert history["pruned"] == members  # the first generation's trials, none after them
    assert history["evaluations"] > 2 * members


def test_galilean_invariance():
    """The column reads the acceleration: a uniform velocity changes nothing (a record whose
    first sample is its own rest; from rest at 0 m/s, 0.3 m/s would be a jump, a real
    shock)."""
    u = _harmonic(10.0, 4.0)
    phys = _phys(*RIG_LIKE)[None]
    a = causal_intervals(phys, u[None], FS, N_BALLS, N_SUB, from_rest=False)
    b = causal_intervals(phys, u[None] + 0.3, FS, N_BALLS, N_SUB, from_rest=False)
    assert np.max(np.abs(a)) > 1.0
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.max(np.abs(a)))


def test_column_dissipates():
    """The column's physical force (unit filter) takes energy from a harmonic motion: the work
    of the tank on the liquid over the steady cycles is positive, and zero below 1 g."""
    for f_hz, acc in ((8.0, 2.0), (12.0, 4.0), (20.0, 6.0)):
        u = _harmonic(f_hz, acc, seconds=4.0)
        force = grey_features(_phys(*RIG_LIKE), _unit_taps(), u, FS, N_BALLS, N_SUB,
                              N_PAST)[0, :, 0]
        # the force at k is the mean over [t_{k-1}, t_k]; the tank's velocity there is the mean
        k = np.arange(int(FS), u.size)
        work = -np.sum(force[k] * 0.5 * (u[k] + u[k - 1])) / FS
        assert work > 0, (f_hz, acc, work)


def test_numba_and_jax_steps_agree():
    """The fitted model's JAX step and the identification's numba kernel are one arithmetic:
    their features agree to round-off on a record with impacts (the column's contacts are
    thresholds, so the tolerance is the features' own sensitivity to a 1e-13 change of the
    input, measured here)."""
    u = _harmonic(11.0, 5.0, seconds=1.5)
    phys = _phys(*RIG_LIKE)
    taps = np.random.default_rng(0).uniform(0.0, 0.05, (N_PAST + 1) * N_SUB)

    def nb_feats(v: np.ndarray) -> np.ndarray:
        return grey_features(phys, taps, v, FS, N_BALLS, N_SUB, N_PAST)[0]

    with jax.enable_x64(True):
        def body(st, v):
            st2 = physics_step(jnp.asarray(phys), jnp.asarray(taps), st, v, FS, N_SUB, N_PAST)
            return st2, st[-1]

        _, out = jax.lax.scan(body, physics_rest((), N_BALLS, N_SUB, N_PAST), jnp.asarray(u))
        jx = np.asarray(out)
    ref = nb_feats(u)
    tol = perturbation_tolerance(nb_feats, u) + 1e-12
    scale = np.max(np.abs(ref))
    assert scale > 1.0
    assert np.max(np.abs(jx - ref)) <= tol * scale


@pytest.mark.parametrize("windows, n_balls, n_sub", [(16, 10, 8), (17, 4, 8), (40, 10, 6)])
def test_windows_as_lanes_are_the_windows_one_by_one(windows, n_balls, n_sub):
    """The search's kernel (the windows as the vector axis, in blocks) gives each window's
    column to the bit: random parameter sets, windows of violent random motion (every
    regime: at rest, released, flying, against the lid, landing), from rest or not, a warm-up or
    not, blocks that are not whole (17 and 40 windows)."""
    rng = np.random.default_rng(windows)
    lo, hi = np.array(list(PHYSICS_BOUNDS.values())).T
    phys = np.stack([_phys(*(lo + (hi - lo) * rng.random(lo.size))) for _ in range(2)]
                    + [_phys(*RIG_LIKE)])
    n = 400
    accel = rng.standard_normal((windows, n)) * rng.uniform(0.5, 6.0, (windows, 1)) * G
    u = np.cumsum(accel, axis=1) / FS * np.linspace(0.0, 1.0, n)  # ramped from rest
    assert windows >= LANES_FROM
    for from_rest, predict_from in ((True, 0), (False, 99)):
        want = np.empty((3, windows, n, 3, n_sub))
        _causal_batch(phys, u, FS, n_balls, n_sub, from_rest, predict_from, want)
        got = causal_intervals(phys, u, FS, n_balls, n_sub, from_rest=from_rest,
                               predict_from=predict_from)
        assert np.max(np.abs(want)) > 1.0  # impacts
        assert np.any(want[..., 1:, :] != want[..., :1, :])  # the predictions differ
        np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
        # blocks of another size (the last one short), as numba's threads may get them
        got = np.full_like(want, np.nan)
        _causal_lanes(phys, u, FS, n_balls, n_sub, from_rest, predict_from, got, 7)
        np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
    # no parameter set: nothing to simulate, as window by window
    assert causal_intervals(phys[:0], u, FS, n_balls, n_sub).shape == (0, windows, n, 3, n_sub)


def test_design_rows_of_several_records_and_a_warm_up():
    """The search's two shortcuts change none of its numbers: the output filter's rows of a
    batch of windows are each window's rows (as written out, row by row, below), and the
    predictions left out of a warm-up leave the committed forces and the later predictions
    as they were."""
    u = np.stack([_harmonic(f, a, seconds=1.0) for f, a in ((9.0, 3.0), (14.0, 5.0))])
    phys = _phys(*RIG_LIKE)[None]
    full = causal_intervals(phys, u, FS, N_BALLS, N_SUB, from_rest=False)[0]
    part = causal_intervals(phys, u, FS, N_BALLS, N_SUB, from_rest=False, predict_from=200)[0]
    assert np.max(np.abs(full[:, 200:])) > 1.0
    np.testing.assert_array_equal(part[..., 0, :], full[..., 0, :])
    np.testing.assert_array_equal(part[:, 200:], full[:, 200:])
    assert np.all(part[:, :200, 1:] == 0.0)
    # the search's one buffer, full of an earlier generation's numbers: every one written again
    buf = np.full((1, *u.shape, 3, N_SUB), np.nan)
    causal_intervals(phys, u, FS, N_BALLS, N_SUB, from_rest=False, out=buf)
    again = causal_intervals(phys, u, FS, N_BALLS, N_SUB, from_rest=False, predict_from=200,
                             out=buf)
    assert again is buf
    np.testing.assert_array_equal(again[0], part)
    with pytest.raises(ROMError, match="C-contiguous float64 array of shape"):
        causal_intervals(phys, u, FS, N_BALLS, N_SUB, out=buf[..., :4])
    rows = design_rows(full, N_PAST)
    assert rows.shape == (2, u.shape[1], (N_PAST + 1) * N_SUB)
    for w in range(2):
        np.testing.assert_array_equal(rows[w], design_rows(full[w], N_PAST))
        o = full[w]
        for k in (0, 1, 3, 250, u.shape[1] - 1):
            want = np.zeros((N_PAST + 1, N_SUB))
            if k >= 1:
                want[0], want[1] = o[k - 1, 2, ::-1], o[k - 1, 1, ::-1]
            for j in range(N_PAST - 1):
                if k - 1 - j >= 0:
                    want[2 + j] = o[k - 1 - j, 0, ::-1]
            np.testing.assert_array_equal(rows[w, k], want.reshape(-1))


@pytest.mark.parametrize(("windows", "n", "ns", "n_past", "skip"),
                         [(3, 40, 8, 6, 10), (2, 30, 4, 2, 0), (1, 20, 3, 5, 1),
                          (4, 50, 8, 6, 3), (2, 25, 2, 9, 5), (5, 60, 8, 6, 25)])
def test_filter_sums_without_the_rows_equal_the_rows(windows, n, ns, n_past, skip):
    """The search's normal equations and filter output, summed from the simulations, are those
    of :func:`design_rows` to round-off: every skip against the lags (rows before the record
    zero, a warm-up longer or shorter than the filter's reach). A sum reordered errs by at most
    (terms) eps times the sum of its terms' magnitudes, which the largest diagonal entry
    bounds (Cauchy-Schwarz): tolerance (rows + 2 n_past) eps of it, x4."""
    rng = np.random.default_rng(n + 7 * skip)
    o = rng.standard_normal((windows, n, 3, ns))
    o[..., 1:, :] *= 3.0  # the predictions larger than the committed forces, as impacts are
    y = rng.standard_normal((windows, n - skip))
    taps = rng.standard_normal((n_past + 1) * ns)
    a = design_rows(o, n_past, skip).reshape(-1, taps.size)
    gram, rhs = filter_normal_equations(o, y, n_past, skip)
    out = filter_output(o, taps, n_past, skip)
    eps = np.finfo(float).eps * 4 * (a.shape[0] + 2 * n_past)
    ata = a.T @ a
    big = np.max(np.diag(ata))
    np.testing.assert_allclose(gram, ata, rtol=0, atol=eps * big)
    np.testing.assert_allclose(rhs, a.T @ y.reshape(-1), rtol=0,
                               atol=eps * np.sqrt(big * np.sum(y**2)))
    np.testing.assert_allclose(out.reshape(-1), a @ taps, rtol=0,
                               atol=eps * np.max(np.abs(a)) * np.sum(np.abs(taps)))
    assert out.shape == (windows, n - skip)
    # too short for the sums' shared range, or not a simulation's layout: said, not guessed
    with pytest.raises(ROMError, match="more than skip \\+ n_past"):
        filter_output(np.ascontiguousarray(o[:, :skip + n_past]), taps, n_past, skip)
    with pytest.raises(ROMError, match="C-contiguous float64"):
        filter_normal_equations(o[..., ::-1], y, n_past, skip)
    with pytest.raises(ROMError, match="y must have shape"):
        filter_normal_equations(o, y[:, 1:], n_past, skip)
    with pytest.raises(ROMError, match="skip must be >= 0"):
        filter_output(o, taps, n_past, -1)


@pytest.mark.slow
def test_physics_identifies_itself():
    """A force made by the column with known parameters identifies them again (as a linear
    system its linear model): the gap and the gate, which set *when* the liquid lands, within
    a few per cent; the mass and the contact, which the point-wise error trades against the
    timing, looser; and the identified column fits the force."""
    t = np.arange(int(40 * FS)) / FS
    # a slow sweep of frequency and amplitude over the column's regimes (2-7 g, 7-18 Hz)
    f = 7.0 + 11.0 * t / t[-1]
    acc = G * (2.0 + 5.0 * (0.5 - 0.5 * np.cos(2 * np.pi * t / 13.0)))
    a = acc * np.sin(2 * np.pi * np.cumsum(f) / FS) * np.minimum(1.0, t / 0.5)
    u = np.cumsum(a) / FS
    u -= np.mean(u)
    u[0] = 0.0
    truth = _phys(*RIG_LIKE)
    spec = GreySpec(2, 4, 4, N_BALLS, N_SUB, N_PAST)
    y = grey_features(truth, _unit_taps(), u, FS, N_BALLS, N_SUB, N_PAST)[0, :, 0]
    phys, taps, hist = fit_physics(u, y, FS, spec, TANK.liquid_mass, TANK.ullage,
                                   generations=20, population=8, windows=24, seed=0)
    y_hat = grey_features(phys, taps, u, FS, N_BALLS, N_SUB, N_PAST)[0, :, 0]
    fit = 1.0 - np.linalg.norm(y_hat - y) / np.linalg.norm(y - y.mean())
    assert fit > 0.5
    assert phys[3] == pytest.approx(truth[3], rel=0.05)  # gap
    assert phys[4] == pytest.approx(truth[4], rel=0.15)  # gate rate
    assert phys[5] == pytest.approx(truth[5], rel=0.25)  # gate relaxation
    assert phys[0] == pytest.approx(truth[0], rel=0.3)  # mass
    for k, (lo, hi) in PHYSICS_BOUNDS.items():
        assert lo <= hist[k] <= hi


def _vfa_records(duration: float, seeds: tuple[int, int]):
    """The virtual rig's training and validation records of a harmonic sweep (VFA) of
    ``duration`` s, preprocessed."""
    from sloshrom.io import record_from_measurement
    from sloshrom.rig import VirtualRig
    from sloshrom.signals import vfa

    rig = VirtualRig(TANK)
    rec = []
    for split, seed in zip(("train", "validation"), seeds, strict=True):
        path = vfa(1 / rig.dt, split, duration=duration, tank=TANK, seed=seed)
        rec.append(record_from_measurement(rig.measure(path.acceleration), TANK))
    return rec[0], rec[1]


@pytest.fixture(scope="module")
def tiny_grey(tmp_path_factory):
    """A grey box fitted in seconds on a short harmonic-sweep record of the virtual rig."""
    tr, va = _vfa_records(24.0, (1, 2))
    model = GreyBox(n_states=3, neurons=8, window=10, horizon=40, batch=16, max_epochs=2,
                    steps_per_epoch=5, physics_generations=2, physics_population=3,
                    physics_windows=4, passivity=1.0, cycle_energy=0.1, velocity_offset=0.5)
    model.fit(tr["velocity"], tr["dynamic_force"], fs=tr.fs,
              validation=(va["velocity"], va["dynamic_force"]), fill=0.5)
    path = model.save(tmp_path_factory.mktemp("grey") / "grey.npz")
    return model, path, va


def test_members_share_the_compiled_epoch_and_validation():
    """Two members (other seeds: other columns, so other features of the record) train the
    network with one compilation of its epoch and of its validation's passivity penalty: the
    arrays that differ are the programs' arguments."""
    # 13 s: a length no other test trains on, so the first member must compile
    tr, va = _vfa_records(13.0, (3, 4))
    models, compiled = [], []
    for seed in (1, 2):
        m = GreyBox(n_states=3, neurons=8, window=10, horizon=40, batch=16, max_epochs=2,
                    steps_per_epoch=3, physics_generations=2, physics_population=3,
                    physics_windows=4, passivity=1.0, cycle_energy=0.1, seed=seed)
        with compiled_programs() as names:
            m.fit(tr["velocity"], tr["dynamic_force"], fs=tr.fs,
                  validation=(va["velocity"], va["dynamic_force"]), fill=0.5)
        models.append(m)
        compiled.append(names)
    assert models[0].physics_ != models[1].physics_
    assert compiled[0].count("jit(epoch)") == 1 and compiled[0].count("jit(every_probe)") == 1
    assert "jit(epoch)" not in compiled[1] and "jit(every_probe)" not in compiled[1]
    u = np.asarray(tr["velocity"], dtype=float)  # inside both members' envelope
    assert np.max(np.abs(models[0].predict(u) - models[1].predict(u))) > 0


def test_strictly_proper(tiny_grey):
    """The force at sample k does not read the velocity at k: changing it changes the force
    from k + 1 on only."""
    model, _, va = tiny_grey
    u = np.asarray(va["velocity"][:3000], dtype=float)
    base = model.predict(u)
    k = 2000
    moved = u.copy()
    moved[k] += 0.05
    out = model.predict(moved)
    np.testing.assert_array_equal(out[: k + 1], base[: k + 1])
    assert np.max(np.abs(out[k + 1:] - base[k + 1:])) > 0
    assert not model.model_.feedthrough


def test_step_contract_equals_predict(tiny_grey):
    """The coupled beam's step (the JAX column) gives predict's force (the numba column)."""
    model, _, va = tiny_grey
    u = np.asarray(va["velocity"][:2500], dtype=float)
    with jax.enable_x64(True):
        st = jax.tree_util.tree_map(jnp.asarray, model.init_state())
        _, ys = jax.lax.scan(lambda s, v: model.step(s, v), st, jnp.asarray(u))
    ref = model.predict(u)
    tol = perturbation_tolerance(model.predict, u) + 1e-12
    assert np.max(np.abs(np.asarray(ys) - ref)) <= tol * np.max(np.abs(ref))


def test_file_round_trip(tiny_grey):
    """Saved and loaded (no pickle), the model predicts the same force, with its physics."""
    model, path, va = tiny_grey
    again = load_model(path)
    u = np.asarray(va["velocity"][:4000], dtype=float)
    np.testing.assert_array_equal(again.predict(u), model.predict(u))
    assert again.physics_ == model.physics_
    assert set(again.physics_) == {"mass", "stiffness", "damping", "gap", "gate_rate",
                                   "gate_relaxation", "coherence_g"}
    assert again.history_["search"]["generations"] >= 1


def test_rest_is_zero_force(tiny_grey):
    """At rest the model gives no force (physics at rest, network at its equilibrium), to the
    round-off of the output's affine scaling."""
    model, _, _ = tiny_grey
    half = model.scaler_.out_half_range
    assert np.max(np.abs(model.predict(np.zeros(500)))) <= 1e-13 * half


def test_units_other_than_velocity_and_force_refused():
    with pytest.raises(Exception, match="velocity in m/s"):
        GreyBox(units=("V", "m")).fit(np.zeros(2000), np.ones(2000), fs=FS)


def test_registered_with_the_tank_scales():
    mc = CLASSES["grey"]
    assert mc.class_name == "GreyBox"
    h = mc.with_tank({"liquid_mass": 0.0, "ullage": 0.0}, Tank(fill=0.25))
    assert h == {"liquid_mass": Tank(fill=0.25).liquid_mass, "ullage": Tank(fill=0.25).ullage}
    assert mc.with_tank({"liquid_mass": 2.0}, Tank())["liquid_mass"] == 2.0


@pytest.mark.parametrize("fs", [500.0, 1000.0, 250.0, 37.0])
def test_search_spectra_are_scipys_stft_to_the_bit(fs):
    """The search's spectral term, in real arithmetic, is the magnitude of
    ``scipy.signal.stft`` (complex window) to the bit, at every resolution the rate gives."""
    from scipy import signal as sps

    from sloshrom.rom.grey.training import _STFT, _spectra

    x = np.random.default_rng(3).standard_normal((3, int(2 * fs))) * 4.0
    got = _spectra(x, fs)
    want = []
    for seg, hop in _STFT:
        s, h = max(4, int(round(seg * fs / 500.0))), max(1, int(round(hop * fs / 500.0)))
        want.append(np.abs(sps.stft(x, nperseg=s, noverlap=s - h, axis=-1, boundary=None,
                                    padded=False)[2]))
    assert len(got) == len(want) == 3
    for g, w in zip(got, want, strict=True):
        assert g.shape == w.shape and g.strides == w.strides
        np.testing.assert_array_equal(g, w)
