"""Ensembles of ROMs: training by seed, mean prediction, step contract, pytree, file, CLI."""

from __future__ import annotations

import json
import math
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from typer.testing import CliRunner

from helpers import model_parts, smooth_io, write_model_parts
from sloshrom import rom
from sloshrom.cli import app
from sloshrom.io import Record, write_record
from sloshrom.models import SloshingModel, envelope_of, is_jax_model
from sloshrom.rom import modelfile
from sloshrom.rom.ensemble import Ensemble, spread
from sloshrom.rom.errors import EnvelopeWarning, NotFittedError, ROMError
from sloshrom.rom.modelfile import ModelFileError
from sloshrom.rom.onnx import onnx_model
from sloshrom.rom.parallel import run_tasks
from sloshrom.rom.tdnn.estimators import NFIR, NOE

FS = 500.0


@pytest.fixture(scope="module")
def fitted():
    u, y = smooth_io()
    template = NFIR(delays=3, neurons=4, max_epochs=3, seed=7)
    return Ensemble(template, n_members=3).fit(u, y, FS, validation=smooth_io(600, 2),
                                                scheduler="sequential")


def test_fit_returns_self_members_differ_by_seed(fitted):
    ens = fitted
    assert [m.seed for m in ens.members_] == ens.seeds_ == [7, 8, 9]
    assert all(type(m) is NFIR and m.get_params()["delays"] == 3 for m in ens.members_)
    assert not np.array_equal(ens.members_[0].params_["W"], ens.members_[1].params_["W"])
    assert ens.fs_ == FS and ens.dt == 1 / FS and len(ens.history_) == 3
    # same data: the members' scalers and envelopes agree, the union is theirs
    assert ens.scaler_ == ens.members_[0].scaler_
    assert ens.envelope_ == ens.members_[0].envelope_
    assert ens.template.seed == 7 and not hasattr(ens.template, "params_")  # not fitted
    assert is_jax_model(ens) and isinstance(ens, SloshingModel)
    assert envelope_of(ens) is not None
    assert ens.n_params == 3 * ens.members_[0].n_params


def test_threads_give_the_same_members_as_sequential(fitted):
    u, y = smooth_io()
    ens = Ensemble(NFIR(delays=3, neurons=4, max_epochs=3), n_members=2, seeds=[8, 7])
    seen = []
    out = ens.fit(u, y, FS, validation=smooth_io(600, 2), scheduler="threads", n_workers=2,
                  progress=lambda k, m: seen.append((k, m.seed)))
    assert out is ens and sorted(seen) == [(0, 8), (1, 7)]
    for k, s in enumerate([8, 7]):
        ref = fitted.members_[s - 7]
        np.testing.assert_array_equal(ens.members_[k].params_["W"], ref.params_["W"])


def test_predict_is_the_mean_of_the_members(fitted):
    u = smooth_io(400, 3)[0]
    each = fitted.member_predictions(u)
    assert each.shape == (3, 400)
    for k, m in enumerate(fitted.members_):
        np.testing.assert_array_equal(each[k], m.predict(u))
    np.testing.assert_array_equal(fitted.predict(u), np.mean(each, axis=0))
    np.testing.assert_array_equal(fitted.simulate(u, None), fitted.predict(u))
    batch = np.stack([u, 0.5 * u])
    assert fitted.predict(batch).shape == (2, 400)
    assert fitted.member_predictions(batch).shape == (3, 2, 400)


def test_step_reproduces_predict_and_is_the_mean_of_member_steps(fitted):
    u = smooth_io(300, 4)[0]
    with jax.enable_x64(True):
        state = fitted.init_state()
        assert isinstance(state, tuple) and len(state) == 3

        @jax.jit
        def run(model, u):
            def body(s, v):
                return model.step(s, v, 0.0)
            return jax.lax.scan(body, model.init_state(), u)[1]

        y = np.asarray(run(fitted, jnp.asarray(u)))
        np.testing.assert_allclose(y, fitted.predict(u), rtol=1e-10, atol=1e-10)
        # one step: the mean of the members' steps, the members' new states
        s1, f = fitted.step(state, 0.1, 0.0)
        singles = [m.step(m.init_state(), 0.1, 0.0) for m in fitted.members_]
        np.testing.assert_allclose(f, np.mean([float(x[1]) for x in singles]), rtol=1e-14)
        for a, (b, _) in zip(s1, singles, strict=True):
            np.testing.assert_array_equal(a, b)


def test_pytree_members_are_children(fitted):
    leaves, treedef = jax.tree_util.tree_flatten(fitted)
    assert len(leaves) == 3 * 8  # W, b, c, c0 and four scaler bounds per member
    back = jax.tree_util.tree_unflatten(treedef, leaves)
    assert type(back) is Ensemble and back.seeds_ == fitted.seeds_ and back.fs_ == FS
    u = smooth_io(100, 5)[0]
    np.testing.assert_array_equal(back.predict(u), fitted.predict(u))


def test_coupled_free_response_runs_the_ensemble(fitted):
    from sloshrom.beam.simulation.coupled import CoupledSimulator, free_response
    from sloshrom.beam.simulation.structure import ModalModel

    modal = ModalModel.from_beam()
    assert CoupledSimulator(fitted, modal).backend == "jax"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the beam leaves the tiny envelope
        r = free_response(fitted, modal, tip_displacement=0.002, duration=0.1)
    assert all(np.all(np.isfinite(np.asarray(v))) for v in r.values())
    assert np.any(np.asarray(r["q"]) != 0)


def test_envelope_warning_once_for_the_union(fitted):
    u = np.full(50, 10 * fitted.envelope_["input_max"])
    with pytest.warns(EnvelopeWarning, match="training envelope") as rec:
        fitted.predict(u)
    assert len([w for w in rec if w.category is EnvelopeWarning]) == 1
    assert rec[0].filename == __file__  # points at the caller


def test_envelope_quiet_silences_this_thread_only():
    import threading
    import warnings

    from sloshrom.models import check_envelope, envelope_quiet

    class Model:
        envelope_ = {"input_min": -1.0, "input_max": 1.0, "unit": "m/s"}

    assert envelope_of(Model()) is not None
    outside = np.array([0.0, 2.0])
    with pytest.warns(EnvelopeWarning, match="outside the training envelope"):
        check_envelope(Model(), outside)
    other: list[list[warnings.WarningMessage]] = []
    inside = threading.Event()
    checked = threading.Event()

    def in_other_thread():
        inside.wait()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_envelope(Model(), outside)
        other.append(caught)
        checked.set()

    t = threading.Thread(target=in_other_thread)
    t.start()
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnvelopeWarning)
        with envelope_quiet():
            check_envelope(Model(), outside)  # no warning: an error here
            inside.set()
            checked.wait(10)
    t.join()
    # the other thread, while this one was quiet: warned
    assert [w.category for w in other[0]] == [EnvelopeWarning]
    with pytest.warns(EnvelopeWarning):  # quiet no more
        check_envelope(Model(), outside)


def test_one_member_ensemble_equals_the_member(fitted):
    m = fitted.members_[0]
    one = Ensemble.from_members([m])
    u = 0.5 * smooth_io(300, 6)[0]
    np.testing.assert_array_equal(one.predict(u), m.predict(u))
    with jax.enable_x64(True):
        s, f = one.step(one.init_state(), 0.2, 0.0)
        s_m, f_m = m.step(m.init_state(), 0.2, 0.0)
    assert float(f) == float(f_m)


def test_save_load_round_trip_bit_identical(fitted, tmp_path):
    p = fitted.save(tmp_path / "ens")
    assert p.name == "ens.npz"
    back = rom.load_model(p)
    assert type(back) is Ensemble and back.member_class == "NFIR"
    assert back.seeds_ == fitted.seeds_ and back.fs_ == FS
    assert back.template.get_params() == fitted.template.get_params()
    assert back.envelope_ == fitted.envelope_
    assert json.dumps(back.history_) == json.dumps(fitted.history_)  # NaN != NaN
    u = smooth_io(500, 7)[0]
    np.testing.assert_array_equal(back.predict(u), fitted.predict(u))
    np.testing.assert_array_equal(back.member_predictions(u), fitted.member_predictions(u))
    with np.load(p, allow_pickle=False) as z:
        meta = json.loads(str(z["metadata"]))
        assert z["W"].shape == (3, 4, 3) and z["c0"].shape == (3,)
    assert meta["class"] == "Ensemble" and meta["format_version"] == 2
    assert meta["n_members"] == 3 and [m["seed"] for m in meta["members"]] == [7, 8, 9]


def _edit(key, value):
    def edit(meta, arrays):
        obj = meta
        *path, last = key
        for k in path:
            obj = obj[k]
        obj[last] = value
    return edit


@pytest.mark.parametrize("edit,match", [
    (_edit(["n_members"], 2), r"'members': must list n_members = 2 members"),
    (_edit(["members", 1, "seed"], 7), r"'members\[1\]\.seed': must differ"),
    (_edit(["members", 0, "scaler", "in_max"], -5.0), r"'members\[0\]\.scaler\.in_max'"),
    (_edit(["members", 2, "envelope", "frequency_band"], [1.0, 1e5]),
     r"'members\[2\]\.envelope\.frequency_band'"),
    (_edit(["member_class"], "Sequential"), r"'member_class'"),
    (_edit(["n_members"], 65), r"'n_members': must be <= 64"),
    (_edit(["hyperparameters", "neurons"], 5), r"parameter W tampered: expected float "
                                               r"\(3, 5, 3\) for 3 members"),
    (_edit(["format_version"], 1), "an ensemble file has format version 2, this one says 1"),
    (lambda m, a: a.update(W=a["W"][:2]), r"parameter W tampered: expected float \(3, 4, 3\)"),
    (lambda m, a: a["c0"].__setitem__(1, np.nan), "parameter c0 contains NaN"),
    (lambda m, a: m["members"].append(m["members"][0]), r"'members'"),
])
def test_hostile_ensemble_file_is_rejected_naming_the_problem(fitted, tmp_path, edit, match):
    meta, arrays = model_parts(fitted.save(tmp_path / "ens.npz"))
    arrays = {k: np.array(v) for k, v in arrays.items()}
    edit(meta, arrays)
    p = write_model_parts(tmp_path / "bad.npz", meta, arrays)
    with pytest.raises(ModelFileError, match=match):
        rom.load_model(p)


def test_corrupt_ensemble_file_fails_the_checksum(fitted, tmp_path):
    meta, arrays = model_parts(fitted.save(tmp_path / "ens.npz"))
    arrays["W"] = arrays["W"] + 1e-12
    p = write_model_parts(tmp_path / "bad.npz", meta, arrays, recompute=False)
    with pytest.raises(ModelFileError, match="checksum mismatch"):
        rom.load_model(p)
    p.write_bytes(p.read_bytes()[:-200])
    with pytest.raises(ModelFileError):
        rom.load_model(p)


def test_single_model_files_stay_version_1_and_cannot_claim_2(fitted, tmp_path):
    p = fitted.members_[0].save(tmp_path / "one.npz")
    meta, arrays = model_parts(p)
    assert meta["format_version"] == modelfile.FORMAT_VERSION == 1
    assert type(rom.load_model(p)) is NFIR
    meta["format_version"] = 2
    with pytest.raises(ModelFileError, match="a single NFIR model file has format version 1"):
        rom.load_model(write_model_parts(tmp_path / "two.npz", meta, arrays))


def test_bad_ensemble_arguments():
    u, y = smooth_io(300)
    t = NFIR(delays=3, neurons=4, max_epochs=1)
    for ens, match in [
        (Ensemble(t, n_members=0), "n_members must be an integer in 1..64"),
        (Ensemble(t, n_members=2, seeds=[1, 1]), "seeds must be distinct"),
        (Ensemble(t, n_members=3, seeds=[1, 2]), "seeds lists 2 seeds for n_members = 3"),
        (Ensemble(t, n_members=2, seeds=[-1, 2]), "seeds must be integers >= 0"),
        (Ensemble("nfir", n_members=2),
         r"template must be an unfitted estimator whose members differ by their seed "
         r"\(NFIR, NOE, NSS, GreyBox\)"),
        (Ensemble(NFIR(delays=0), n_members=2), "delays"),
    ]:
        with pytest.raises(ROMError, match=match):
            ens.fit(u, y, FS, scheduler="sequential")
    with pytest.raises(NotFittedError):
        Ensemble(t).predict(u)
    assert not isinstance(Ensemble(t), SloshingModel)  # unfitted: no dt
    with pytest.raises(ROMError, match="no parameter"):
        Ensemble(t).set_params(delays=3)
    e = Ensemble(t).set_params(n_members=2, template__neurons=6)
    assert e.get_params()["template__neurons"] == 6 and e.n_members == 2


def test_from_members_refuses_mixed_members(fitted):
    a = fitted.members_[0]
    other = NOE(delays=2, neurons=4)
    with pytest.raises(ROMError, match="member 1 is a NOE"):
        Ensemble.from_members([a, other])
    with pytest.raises(ROMError, match="seeds must be distinct"):
        Ensemble.from_members([a, a])


def test_onnx_export_of_an_ensemble_fails_clearly(fitted):
    with pytest.raises(ROMError, match="ensemble .*cannot be exported to ONNX"):
        onnx_model(fitted)


def test_spread():
    s = spread([1.0, 3.0, float("nan")])
    assert s["mean"] == 2.0 and s["std"] == pytest.approx(math.sqrt(2)) and s["n"] == 2
    assert len(s["values"]) == 3 and math.isnan(s["values"][2])
    assert spread([4.0]) == {"mean": 4.0, "std": 0.0, "n": 1, "values": [4.0]}
    e = spread([])
    assert e["n"] == 0 and math.isnan(e["mean"]) and math.isnan(e["std"])


def test_run_tasks_keeps_the_order_of_the_items():
    done = []
    out = run_tasks(divmod, [7, 9, 11], shared=(2,), scheduler="threads", n_workers=2,
                    done=lambda i, r: done.append(i))
    assert out == [(3, 1), (4, 1), (5, 1)] and sorted(done) == [0, 1, 2]
    assert run_tasks(divmod, [5], args=(3,), scheduler="sequential") == [(1, 2)]


def test_cli_max_members_matches_the_format():
    from sloshrom.cli import rom as cli_rom

    assert cli_rom.MAX_MEMBERS == modelfile.MAX_MEMBERS


@pytest.mark.long
def test_cli_train_ensemble_writes_a_loadable_ensemble(tmp_path):
    paths = []
    for name, seed, n in (("train", 1, 2000), ("validation", 2, 600)):
        u, y = smooth_io(n, seed)
        rec = Record(np.arange(n) / FS, FS, {"velocity": u, "dynamic_force": y},
                     {"velocity": "m/s", "dynamic_force": "N"}, {})
        paths.append(write_record(rec, tmp_path / f"{name}.nc"))
    out = tmp_path / "ens.npz"
    res = CliRunner().invoke(app, [
        "train", "--data", str(paths[0]), "--validation", str(paths[1]), "--out", str(out),
        "--delays", "3", "--neurons", "4", "--max-epochs", "2", "--seed", "3",
        "--ensemble", "2", "--scheduler", "threads"])
    assert res.exit_code == 0, res.output
    assert "member 0 (seed 3): validation MSE" in res.output
    assert "member 1 (seed 4)" in res.output and "+-" in res.output
    ens = rom.load_model(out)
    assert type(ens) is Ensemble and ens.seeds_ == [3, 4]
    # commands that read a model file take the ensemble
    pred = tmp_path / "pred.nc"
    res = CliRunner().invoke(app, ["predict", "--model", str(out), "--data", str(paths[1]),
                                   "--out", str(pred)])
    assert res.exit_code == 0 and "MSE" in res.output, res.output
    res = CliRunner().invoke(app, ["export", "onnx", str(out), str(tmp_path / "e.onnx")])
    assert res.exit_code == 2 and "cannot be exported to ONNX" in res.output, res.output
    assert not (tmp_path / "e.onnx").exists()
    res = CliRunner().invoke(app, [
        "train", "--data", str(paths[0]), "--validation", str(paths[1]),
        "--out", str(tmp_path / "x.npz"), "--ensemble", "65"])
    assert res.exit_code == 2 and "--ensemble" in res.output, res.output


@pytest.mark.slow
def test_fit_through_a_dask_local_cluster(fitted):
    u, y = smooth_io()
    ens = Ensemble(NFIR(delays=3, neurons=4, max_epochs=3, seed=7), n_members=2)
    ens.fit(u, y, FS, validation=smooth_io(600, 2), n_workers=2)  # a new LocalCluster
    for a, b in zip(ens.members_, fitted.members_, strict=False):
        np.testing.assert_array_equal(a.params_["W"], b.params_["W"])


def test_weight_limits_are_checked_before_any_training(monkeypatch):
    """A network or an ensemble that no model file holds is refused by fit, not by save."""
    import sloshrom.rom.ensemble as ens_mod
    import sloshrom.rom.tdnn.estimators as tdnn_estimators
    from sloshrom.pipeline.settings import MAX_MODEL_WEIGHTS

    assert MAX_MODEL_WEIGHTS == modelfile.MAX_WEIGHTS  # the configuration's copy of the limit

    def no_training(*args, **kwargs):
        raise AssertionError("trained before the limit was checked")

    monkeypatch.setattr(ens_mod, "run_tasks", no_training)
    u, y = smooth_io(2000)
    ens = Ensemble(NFIR(delays=70, neurons=950), n_members=64)
    with pytest.raises(ROMError, match=r"64 members of NFIR\(70, 950\) have 64 x 66500 = "
                                       r"4256000 weights \(950 neurons x 70 regressor entries "
                                       r"each\), more than 4194304"):
        ens.fit(u, y, fs=500.0, scheduler="sequential")
    monkeypatch.setattr(tdnn_estimators.training, "train", no_training)
    with pytest.raises(ROMError, match=r"NFIR\(2000, 4096\) has 8192000 weights \(4096 neurons "
                                       r"x 2000 regressor entries\), more than 4194304"):
        NFIR(delays=2000, neurons=4096).fit(u, y, fs=500.0)
    with pytest.raises(ROMError, match=r"delays must be distinct integers in \[1, 10000\], "
                                       r"got \[20000\]"):
        NFIR(delays=[20000], neurons=3).fit(u, y, fs=500.0)


def test_an_input_that_does_not_oscillate_is_named_as_such(monkeypatch):
    """The passive recipe needs motion about rest: say so, not "passivity probes need ..."."""
    import sloshrom.rom.tdnn.estimators as tdnn_estimators

    monkeypatch.setattr(tdnn_estimators.training, "train", lambda *a, **k: pytest.fail("trained"))
    u, y = smooth_io(2000)
    with pytest.raises(ROMError, match=r"the input 'velocity' does not oscillate about rest "
                                       r"\(it stays between 0\.01 and [\d.]+ m/s, never "
                                       r"changing sign\): passivity and cycle_energy"):
        NFIR(delays=4, neurons=3, passivity=1.0, cycle_energy=0.1, trainer="adam").fit(
            np.abs(u) + 0.01, y, fs=500.0)


def _forged_fills(tmp_path, fills):
    """An ensemble of NFIRs identified at fill 0.5, its file forged so that member k says it
    was identified at ``fills[k]`` (None: no fill; checksum recomputed: a consistent-looking
    file). Returns the file."""
    u, y = smooth_io()
    ens = Ensemble(NFIR(delays=3, neurons=4, max_epochs=2, seed=7), n_members=len(fills)).fit(
        u, y, FS, scheduler="sequential", fill=0.5)
    meta, arrays = model_parts(ens.save(tmp_path / "ens.npz"))
    for m, f in zip(meta["members"], fills, strict=True):
        if f is None:
            del m["envelope"]["fill_min"], m["envelope"]["fill_max"]
        else:
            m["envelope"]["fill_min"] = m["envelope"]["fill_max"] = f
    return write_model_parts(tmp_path / "forged.npz", meta, arrays)


def test_the_members_of_an_ensemble_are_identified_at_one_fill(tmp_path):
    """A member forged to fill 0.3 beside one at 0.5: the envelope's union of their ranges
    (0.3 to 0.5) passed a fill check at either, running a member at a fill it was not
    identified at. The file is refused when read, naming the member and both fills."""
    from sloshrom.rom.family import at_fill

    with pytest.raises(ModelFileError, match=r"forged\.npz: ensemble member 1 was identified at "
                                             r"fill 30\.0%, member 0 was identified at fill "
                                             r"50\.0%: the members of an ensemble are "
                                             r"identified at one fill"):
        rom.load_model(_forged_fills(tmp_path, [0.5, 0.3]))
    with pytest.raises(ModelFileError, match=r"ensemble member 2 records no fill, member 0 was "
                                             r"identified at fill 50\.0%"):
        rom.load_model(_forged_fills(tmp_path, [0.5, 0.5, None]))
    with pytest.raises(ModelFileError, match=r"member 1 was identified at fill 50\.0%, member 0 "
                                             r"records no fill"):
        rom.load_model(_forged_fills(tmp_path, [None, 0.5]))
    # within the gauge tolerance (0.5 %) one fill; the model runs there
    ens = rom.load_model(_forged_fills(tmp_path, [0.5, 0.504]))
    assert at_fill(ens, 0.5) is ens
    members = rom.load_model(_forged_fills(tmp_path, [0.5, 0.5])).members_
    members[1].envelope_["fill_min"] = members[1].envelope_["fill_max"] = 0.75
    with pytest.raises(ROMError, match=r"^ensemble member 1 was identified at fill 75\.0%"):
        Ensemble.from_members(members)
