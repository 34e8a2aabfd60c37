"""Ensembles in the beam tests (each member coupled alone, the ROM the members' mean) and
Table 2 cells that carry a value or the reason they have none (LSCF fallbacks included)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from helpers import LinearDamper, smooth_io
from sloshrom.beam.compare import analysed_test, compare_rows
from sloshrom.beam.damping.columns import table2_rows
from sloshrom.beam.damping.estimators import ClusterAttempt, LscfH1, RandomTest
from sloshrom.beam.damping.tables import (
    damping_band_table,
    damping_summary,
    member_damping_datasets,
    missing_cells,
    mode1_damping_dataset,
    mode1_damping_table,
    mode1_decay,
)
from sloshrom.beam.damping.uncertainty import estimate_random
from sloshrom.beam.errors import BeamError
from sloshrom.beam.results import write_table
from sloshrom.beam.simulation.cases import simulate_cases
from sloshrom.beam.simulation.coupled import free_response, random_response
from sloshrom.beam.simulation.members import Members, combine_estimates
from sloshrom.beam.simulation.structure import coupled_frozen_modes
from sloshrom.config import Tank
from sloshrom.pipeline.beam import coupled_model, member_spread
from sloshrom.pipeline.experiment import cell_text
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.tdnn.estimators import NFIR

FS = 500.0
LEVELS = [0.1]


@pytest.fixture(scope="module")
def runs(builtin_modal):
    """A single damper and an 'ensemble' of two distinct dampers, coupled to the beam: random
    (40 s, 0.1 g) and free responses, the members also run one by one as single cases."""
    tank = Tank()
    f1 = float(coupled_frozen_modes(builtin_modal, tank.liquid_mass)[0][0])
    a, b = LinearDamper(0.5, 1 / FS), LinearDamper(2.0, 1 / FS)
    models = {"one": LinearDamper(1.0, 1 / FS), "rom": Members((a, b)), "a": a, "b": b}

    def rand(m, fs):
        return random_response(m, builtin_modal, LEVELS, 40.0, 0, tank=tank, output_fs=fs)

    def free(m, fs):
        return free_response(m, builtin_modal, 0.0146, 6.0, tank, fs)

    return {"f1": f1, "modal": builtin_modal, "random": simulate_cases(models, rand, FS),
            "free": simulate_cases(models, free, FS)}


@pytest.fixture(scope="module")
def member_tables(runs) -> dict:
    """Table 2 of each member of the 'ensemble' case (its random response), analysed once for
    the tests that need them (``mode1_damping_table`` without them: in the first test below)."""
    return member_damping_datasets({"rom": runs["random"]["rom"]}, LEVELS, runs["f1"])


def test_each_member_alone_and_the_rom_response_is_their_mean(runs):
    r = runs["random"]
    rom = r["rom"]
    assert rom["n_members"] == 2 and len(rom["members"]) == 2
    for key in ("tank_acceleration", "station_acceleration", "dynamic_force", "q"):
        np.testing.assert_array_equal(rom["members"][0][key], r["a"][key])  # alone
        np.testing.assert_allclose(rom[key], (r["a"][key] + r["b"][key]) / 2, rtol=0,
                                   atol=1e-12 * np.max(np.abs(r["a"][key])))
    # the two members differ: their mean is not either of them
    assert np.max(np.abs(r["a"]["tank_acceleration"] - r["b"]["tank_acceleration"])) > 0.1
    np.testing.assert_array_equal(rom["base_acceleration"], r["a"]["base_acceleration"])
    assert "members" not in r["one"]  # a single model: as before


@pytest.mark.long
def test_rom_row_is_the_mean_of_the_member_rows_with_the_members_spread(runs, member_tables):
    f1, r = runs["f1"], runs["random"]
    members = member_tables
    rows = mode1_damping_table({"rom": r["rom"]}, LEVELS, f1, members=members)
    alone = mode1_damping_table({"a": r["a"], "b": r["b"]}, LEVELS, f1)
    assert len(rows) == 1
    row = rows[0]
    for est in ("lscf_h1", "lscf_output", "half_power"):
        z = np.array([x[est] for x in alone])
        s = np.array([x[f"{est}_std"] for x in alone])
        assert np.all(np.isfinite(z)), est
        assert row[est] == pytest.approx(z.mean(), rel=1e-12)
        assert row[f"{est}_spread"] == pytest.approx(np.std(z, ddof=1), rel=1e-12)
        assert row[f"{est}_members"] == 2 and row[f"{est}_reason"] == ""
        # total variance: the members' estimation variances and their spread
        std = math.sqrt(np.mean(s**2) + np.var(z, ddof=1))
        assert row[f"{est}_std"] == pytest.approx(std, rel=1e-12)
        assert row[f"{est}_low"] < row[est] - 1.9 * std and row[f"{est}_high"] > row[est]
    assert row["n_members"] == 2 and row["case"] == "rom"
    # the estimate of the mean response is another number (the reason for all this)
    assert abs(mode1_damping_table({"x": r["rom"] | {"members": []}}, LEVELS, f1)[0]["lscf_h1"]
               - row["lscf_h1"]) > 1e-5
    # without the members' rows given, the same row (they are analysed then)
    again = mode1_damping_table({"rom": r["rom"]}, LEVELS, f1)[0]
    assert again["lscf_h1"] == row["lscf_h1"] and again["lscf_h1_std"] == row["lscf_h1_std"]


def test_free_decay_bands_summary_and_member_spread_agree(runs, member_tables):
    f1, modal, fr = runs["f1"], runs["modal"], runs["free"]
    cases = {c: fr[c] for c in ("rom", "a", "b")}
    decays = {c: mode1_decay(x, modal, f1) for c, x in cases.items()}
    assert len(decays["rom"].members) == 2 and not decays["a"].members
    bands = damping_band_table(cases, decays, f1)
    rom = [x for x in bands if x["case"] == "rom"]
    for row in rom:
        z = [next(x["zeta"] for x in bands if x["case"] == c and x["band"] == row["band"]
                  and x["method"] == row["method"]) for c in ("a", "b")]
        ok = [v for v in z if np.isfinite(v)]
        if ok:
            assert row["zeta"] == pytest.approx(np.mean(ok), rel=1e-12)
            assert row["members"] == len(ok)
        if len(ok) < 2:  # a member without a value: the row says which and why
            assert "member" in (row["note"] + row["reason"])
    summary = damping_summary(cases, decays)
    rand_tables = member_tables["rom"]
    spread = member_spread(rand_tables, fr["rom"]["members"], decays["rom"], LEVELS)
    for band, s in spread["instantaneous_damping"].items():
        if s["n"]:
            assert summary["rom"][band] == pytest.approx(s["mean"], rel=1e-12)
    t2 = mode1_damping_table({"rom": runs["random"]["rom"]}, LEVELS, f1,
                             members={"rom": rand_tables})[0]
    assert spread["table2"]["0.1"]["mean"] == pytest.approx(t2["lscf_h1"], rel=1e-12)
    assert spread["table2"]["0.1"]["std"] == pytest.approx(t2["lscf_h1_spread"], rel=1e-12)
    assert set(spread["estimators"]) == {"lscf_h1", "lscf_output", "half_power"}


def test_compare_uses_both_sigmas_with_the_rom_combined_std(runs, member_tables):
    f1, r = runs["f1"], runs["random"]
    t2 = mode1_damping_dataset({"one": r["one"], "rom": r["rom"]}, LEVELS, f1,
                               members=member_tables)
    rows = table2_rows(t2)  # what mode1_damping_table returns for these arguments
    meas = analysed_test("one", "random", r["one"], f1, t2.sel(case="one"))
    pred = analysed_test("rom", "random", r["rom"], f1, t2.sel(case="rom"))
    out = {x["estimator"]: x for x in compare_rows(meas, [pred])}
    m, p = rows[0], rows[1]
    for est, c in out.items():
        z = (p[est] - m[est]) / math.hypot(m[f"{est}_std"], p[f"{est}_std"])
        assert c["z"] == pytest.approx(z, rel=1e-12)
        # the ROM's std holds the members' spread: wider than the spread alone would give
        assert p[f"{est}_std"] > p[f"{est}_spread"]


def test_combine_estimates_a_member_without_a_value():
    c = combine_estimates([0.01, float("nan"), 0.02], [1e-4, float("nan"), 2e-4],
                          [0.0098, float("nan"), 0.0196], [0.0102, float("nan"), 0.0204],
                          ["", "no stable pole cluster", ""])
    assert c.zeta == pytest.approx(0.015) and c.members == 2
    assert c.spread == pytest.approx(np.std([0.01, 0.02], ddof=1))
    assert "mean of 2 of 3 members" in c.note and "member1: no stable pole cluster" in c.note
    none = combine_estimates([float("nan")] * 2, [float("nan")] * 2, [float("nan")] * 2,
                             [float("nan")] * 2, ["why a", "why a"])
    assert math.isnan(none.zeta) and none.reason.startswith("no member has an estimate")
    assert "member0, member1: why a" in none.reason
    one = combine_estimates([0.01], [1e-4], [0.0098], [0.0102], [""])
    assert one.spread == 0.0 and one.std == pytest.approx(1e-4)
    assert one.low == pytest.approx(0.0098) and one.note == ""


def test_coupled_model_turns_an_ensemble_into_its_members():
    u, y = smooth_io()
    ens = Ensemble(NFIR(delays=3, neurons=4, max_epochs=2), n_members=2, seeds=[1, 2]).fit(
        u, y, FS, scheduler="sequential")
    m = coupled_model(ens)
    assert isinstance(m, Members) and m.models == tuple(ens.members_)
    assert m.names == ("member0", "member1")
    single = ens.members_[0]
    assert coupled_model(single) is single  # a single ROM: unchanged
    frozen = LinearDamper(0.0, 1 / FS)
    per_tank = coupled_model([ens, frozen])
    assert per_tank.models == ([ens.members_[0], frozen], [ens.members_[1], frozen])
    three = Ensemble.from_members([*ens.members_, NFIR(delays=3, neurons=4, max_epochs=2,
                                                       seed=3).fit(u, y, FS)])
    with pytest.raises(BeamError, match="as many members"):
        coupled_model([ens, three])


# -- every Table 2 cell a value or a reason ------------------------------------------------------
def _noise_record(n: int = 20000, seed: int = 3) -> dict:
    # base and tank independent white noises: no mode for LSCF to find
    rng = np.random.default_rng(seed)
    return {"base_acceleration": rng.standard_normal((1, n)),
            "tank_acceleration": rng.standard_normal((1, n)), "fs": FS,
            "rms_levels_g": np.array([0.1])}


def test_no_cluster_gives_a_reason_in_the_row_markdown_and_console(tmp_path):
    t2 = mode1_damping_dataset({"noise": _noise_record()}, [0.1], 10.19,
                               estimators=["lscf_h1"])
    rows = mode1_damping_table({"noise": _noise_record()}, [0.1], 10.19,
                               estimators=["lscf_h1"])
    row = rows[0]
    assert math.isnan(row["lscf_h1"])
    why = row["lscf_h1_reason"]
    # what was tried: band, model orders and each tolerance of the documented sequence
    for text in ("no stable pole cluster in 5.095-15.29 Hz", "model orders 2-40 poles",
                 "damping tolerance 5 %", "damping tolerance 10 %", "damping tolerance 20 %",
                 "at least 10 poles"):
        assert text in why, (text, why)
    _, md = write_table(rows, tmp_path / "t2")
    assert "no stable pole cluster" in md.read_text(encoding="utf-8")
    assert missing_cells(t2) == [f"noise 0.1 g, LSCF on H1: — ({why})"]
    assert cell_text(float("nan"), float("nan"), float("nan"), why) == f"— ({why})"


def _sdof_record(zeta: float = 0.01, f: float = 10.0, seconds: float = 90.0) -> tuple:
    from scipy import signal
    rng = np.random.default_rng(11)
    wn = 2 * np.pi * f
    b, a, _ = signal.cont2discrete(([2 * zeta * wn, wn**2], [1, 2 * zeta * wn, wn**2]),
                                   1 / FS, method="zoh")
    u = rng.standard_normal(int(seconds * FS) + 5000)
    y = signal.lfilter(np.ravel(b), a, u)
    return u[5000:], y[5000:]


def test_a_fallback_attempt_gives_the_value_and_says_so():
    u, y = _sdof_record()
    test = RandomTest(u, y, FS, 10.0)
    primary = LscfH1().estimate(test)
    assert primary.note == "" and primary.attempt == 0 and np.isfinite(primary.value)
    # a primary attempt that cannot succeed (100 poles from 20 orders): the next one gives it
    est = LscfH1(attempts=(ClusterAttempt(min_poles=100), ClusterAttempt()))
    e = est.estimate(test)
    assert e.value == primary.value and e.attempt == 1
    assert e.note.startswith("fallback attempt 1 (damping tolerance 5 %")
    assert "fewer than 100" in e.note
    # its bootstrap analyses the simulated records with that attempt: an interval
    boot = est.at_attempt(1)
    assert boot.attempts == (ClusterAttempt(),) and boot.first_attempt == 1
    records = RandomTest(np.stack([u, u]), np.stack([y, y]), FS, 10.0)
    # (a stack's Welch H1 is one pass, the single record scipy's: equal to round-off)
    np.testing.assert_allclose(boot.estimate_records(records), [primary.value] * 2, rtol=1e-4)


def test_the_fallbacks_leave_values_of_the_primary_attempt_unchanged():
    u, y = _sdof_record()
    d = estimate_random(u, y, FS, 10.0, estimators=["lscf_h1"], n_resamples=8)
    e = d.estimates["lscf_h1"]
    assert e.note == "" and e.reason == "" and np.isfinite(e.std)
    # the same bootstrap as an estimator with the primary attempt only
    from sloshrom.beam.damping import registry
    old = registry.ESTIMATORS["lscf_h1"]
    try:
        registry.ESTIMATORS["lscf_h1"] = LscfH1(attempts=(ClusterAttempt(),))
        ref = estimate_random(u, y, FS, 10.0, estimators=["lscf_h1"], n_resamples=8)
    finally:
        registry.ESTIMATORS["lscf_h1"] = old
    r = ref.estimates["lscf_h1"]
    assert (e.value, e.std, e.low, e.high) == (r.value, r.std, r.low, r.high)


@pytest.mark.long
def test_table2_with_the_analysis_pool_is_the_table_without_it(runs, member_tables):
    """The beam stage's processes (one a core, spawned) give Table 2 and the members' tables to
    the bit, the single cases and the ensemble's members all started before one is awaited."""
    from sloshrom.pipeline.beam import analysis_pool

    f1, r = runs["f1"], runs["random"]
    cases = {"one": r["one"], "rom": r["rom"]}
    alone = mode1_damping_dataset(cases, LEVELS, f1, members=member_tables)
    with analysis_pool(2) as pool:
        assert pool is not None
        members = member_damping_datasets({"rom": r["rom"]}, LEVELS, f1, pool=pool)
        pooled = mode1_damping_dataset(cases, LEVELS, f1, members=members, pool=pool)
        recomputed = mode1_damping_dataset(cases, LEVELS, f1, pool=pool)
    for a, b in zip(members["rom"], member_tables["rom"], strict=True):
        assert a.identical(b)
    assert pooled.identical(alone)
    assert recomputed.identical(alone)  # the members analysed inside, in the pool too
    with analysis_pool(1) as pool:
        assert pool is None  # one core: the caller's own process


def test_broken_analysis_processes_leave_the_analyses_to_the_stage():
    """Worker processes that cannot start (here: each exits in its initializer, as a script
    without the ``__main__`` guard makes them) break the pool; the analyses then run in the
    stage's process, with a note, and give what they give there."""
    import multiprocessing
    import sys
    import warnings
    from concurrent.futures import ProcessPoolExecutor

    from sloshrom.errors import Note
    from sloshrom.pipeline.beam import collected
    from sloshrom.pipeline.context import in_thread

    def analyses(pool):
        if pool is None:
            return "here"
        return pool.submit(abs, -1).result()

    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                             initializer=sys.exit, initargs=(3,)) as pool:
        with pytest.warns(Note, match="damping analyses ran in this process"):
            assert collected(in_thread(lambda: analyses(pool)), analyses) == "here"
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool, \
            warnings.catch_warnings():
        warnings.simplefilter("error", Note)  # a pool that works: no note
        assert collected(in_thread(lambda: analyses(pool)), analyses) == 1
    assert collected(None, analyses) == "here"


@pytest.mark.long
def test_laboratory_with_the_analysis_pool_is_the_laboratory_without_it(runs, tmp_path):
    """The rig as the laboratory (the beam stage runs it in a thread, its random tests'
    analyses in the pool's processes): the experiment's Table 2, bands and files to the bit."""
    from sloshrom.beam.simulation.structure import CantileverBeam
    from sloshrom.pipeline.beam import analysis_pool, laboratory
    from sloshrom.pipeline.settings import load

    cfg = load(None).beam.model_copy(update={"rms_g": LEVELS})
    beam = CantileverBeam.with_tank(Tank())
    f1, modal = runs["f1"], runs["modal"]
    free, rand = runs["free"]["one"], runs["random"]["one"]
    (tmp_path / "alone").mkdir()
    (tmp_path / "pooled").mkdir()
    alone = laboratory(free, rand, modal, beam, cfg, f1, tmp_path / "alone")
    with analysis_pool(2) as pool:
        assert pool is not None
        pooled = laboratory(free, rand, modal, beam, cfg, f1, tmp_path / "pooled", pool)
    assert pooled["files"] == alone["files"]

    def same(a, b):  # row lists, NaN equal to NaN
        return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)

    assert same(pooled["random"].table_rows(), alone["random"].table_rows())
    assert same(pooled["free"].rows, alone["free"].rows)
    assert math.isfinite(pooled["random"].table_rows()[0]["lscf_h1"])
