"""Fill levels: models record the fill they were identified at, refuse others, and a fill family
blends its members convexly (passive members give a passive blend)."""

from __future__ import annotations

import re
import warnings

import jax
import numpy as np
import pytest
from typer.testing import CliRunner

from helpers import model_parts, smooth_io, write_model_parts
from sloshrom.beam.simulation.coupled import free_response
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.cli import app
from sloshrom.energy import dissipated_energy
from sloshrom.io import Record, read_record, write_record
from sloshrom.models import SloshingModel, is_jax_model
from sloshrom.rom.ensemble import Ensemble
from sloshrom.rom.errors import FillRangeError, ROMError
from sloshrom.rom.family import (
    FILL_TOLERANCE,
    FillBlend,
    FillFamily,
    at_fill,
    check_fill,
    read_family,
    training_fills,
    write_family,
)
from sloshrom.rom.loading import load_model
from sloshrom.rom.modelfile import ModelFileError
from sloshrom.rom.tdnn.estimators import NFIR
from sloshrom.signals import harmonic

FS = 500.0


def _fit(fill, seed=0, scale=1.0):
    u, y = smooth_io()
    return NFIR(delays=3, neurons=4, max_epochs=3, seed=seed).fit(
        u, scale * y, FS, validation=smooth_io(600, 2), fill=fill)


@pytest.fixture(scope="module")
def members():
    return {0.25: _fit(0.25, 1, 2.0), 0.5: _fit(0.5, 2, 1.0), 0.75: _fit(0.75, 3, 0.5)}


@pytest.fixture(scope="module")
def family(members):
    return FillFamily.from_members(members)


def test_fit_records_the_fill_and_the_file_keeps_it(tmp_path, members):
    m = members[0.5]
    assert training_fills(m) == (0.5, 0.5)
    back = load_model(m.save(tmp_path / "m.npz"))
    assert training_fills(back) == (0.5, 0.5)
    check_fill(back, 0.5 + 0.9 * FILL_TOLERANCE)  # within the gauge tolerance
    with pytest.raises(FillRangeError, match=r"identified at fill 50.0%; fill 37.5% is outside"):
        check_fill(back, 0.375, "m.npz")
    # a model that does not say its fill (older files, fit without fill=) is not refused
    u, y = smooth_io()
    plain = NFIR(delays=3, neurons=4, max_epochs=2).fit(u, y, FS)
    assert training_fills(plain) is None
    check_fill(plain, 0.2)
    with pytest.raises(ROMError, match=r"fill must be in \(0, 1\)"):
        NFIR(delays=3, neurons=4, max_epochs=2).fit(u, y, FS, fill=50.0)


@pytest.mark.parametrize("edit, match", [
    ({"fill_min": 0.6}, "fill_max .* must be >= fill_min"),
    ({"fill_max": None}, "fill_min and fill_max must be given together"),
    ({"fill_min": 1.2, "fill_max": 1.3}, "envelope.fill_min"),
])
def test_model_file_rejects_a_bad_fill_range(tmp_path, members, edit, match):
    """A hostile edit (checksum recomputed, as anyone can) is caught by the schema."""
    meta, arrays = model_parts(members[0.5].save(tmp_path / "m.npz"))
    meta["envelope"].update(edit)
    meta["envelope"] = {k: v for k, v in meta["envelope"].items() if v is not None}
    with pytest.raises(ModelFileError, match=match):
        load_model(write_model_parts(tmp_path / "bad.npz", meta, arrays))


def test_ensemble_envelope_is_the_union_of_fills():
    u, y = smooth_io()
    ens = Ensemble(NFIR(delays=3, neurons=4, max_epochs=2), n_members=2).fit(
        u, y, FS, scheduler="sequential", fill=0.4)
    assert training_fills(ens) == (0.4, 0.4)
    assert all(training_fills(m) == (0.4, 0.4) for m in ens.members_)


def test_blend_weights_are_linear_in_fill_and_convex(family):
    np.testing.assert_allclose(family.weights(0.25), [1, 0, 0])
    np.testing.assert_allclose(family.weights(0.375), [0.5, 0.5, 0])
    np.testing.assert_allclose(family.weights(0.6), [0, 0.6, 0.4])
    np.testing.assert_allclose(family.weights(0.75), [0, 0, 1])
    for f in np.linspace(0.25, 0.75, 21):
        w = family.weights(f)
        assert np.all(w >= 0) and abs(w.sum() - 1) < 1e-12 and np.count_nonzero(w) <= 2
    for f in (0.2, 0.8):
        with pytest.raises(FillRangeError, match="25.0% to 75.0%"):
            family.at(f)


def test_blend_predicts_the_weighted_forces_and_steps_agree(family, members):
    u, _ = smooth_io(800, 5)
    blend = family.at(0.375)
    assert isinstance(blend, SloshingModel) and is_jax_model(blend)
    expect = 0.5 * members[0.25].predict(u) + 0.5 * members[0.5].predict(u)
    np.testing.assert_allclose(blend.simulate(u), expect, rtol=1e-12, atol=1e-12)
    with jax.enable_x64(True):  # step follows the caller's JAX precision
        state, out = blend.init_state(), []
        for v in u[:60]:
            state, f = blend.step(state, v, 0.0)
            out.append(float(f))
    np.testing.assert_allclose(out, expect[:60], rtol=1e-9, atol=1e-9)
    # at a trained fill the blend is that member
    np.testing.assert_array_equal(family.at(0.5).simulate(u), members[0.5].predict(u))


def test_blend_energy_is_the_blend_of_energies(family, members):
    """Dissipated energy is linear in the force: convex weights keep passive members passive."""
    h = harmonic(FS, 12.0, 0.002, n_cycles=20)
    w_steady = h.displacement[h.steady]

    def energy(force):
        return float(dissipated_energy(w_steady, force[h.steady], n_cycles=20))

    w = family.weights(0.6)
    e = [energy(m.predict(h.velocity)) for m in family.members_]
    e_blend = energy(family.at(0.6).simulate(h.velocity))
    assert e_blend == pytest.approx(float(np.dot(w, e)), rel=1e-9, abs=1e-15)
    assert min(e[1:]) - 1e-15 <= e_blend <= max(e[1:]) + 1e-15


def test_blend_runs_in_the_coupled_beam_on_jax(family):
    modal = ModalModel.from_beam()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the beam leaves the tiny envelope
        r = free_response(family.at(0.5), modal, tip_displacement=0.002, duration=0.1)
        r1 = free_response(family.members_[1], modal, tip_displacement=0.002, duration=0.1)
    np.testing.assert_allclose(np.asarray(r["q"]), np.asarray(r1["q"]), rtol=1e-12, atol=1e-15)


def test_at_fill_for_single_models_and_families(family, members):
    assert at_fill(members[0.5], None) is members[0.5]
    assert at_fill(members[0.5], 0.5) is members[0.5]
    with pytest.raises(FillRangeError):
        at_fill(members[0.5], 0.3)
    assert isinstance(at_fill(family, 0.3), FillBlend)
    with pytest.raises(FillRangeError, match="give the fill level"):
        at_fill(family, None)


def test_family_refuses_inconsistent_members(members):
    with pytest.raises(ROMError, match="two fills at least"):
        FillFamily.from_members({0.5: members[0.5]})
    with pytest.raises(FillRangeError, match="member at fill 30.0%"):
        FillFamily.from_members({0.3: members[0.25], 0.5: members[0.5]})
    with pytest.raises(ROMError, match="repeat"):
        FillFamily.from_members({0.5: members[0.5], 0.502: members[0.5]})


def test_manifest_round_trip_and_errors(tmp_path, members):
    paths = {f: m.save(tmp_path / "models" / f"m{int(f * 100)}.npz") for f, m in members.items()}
    man = write_family(tmp_path / "family.toml", paths)
    text = man.read_text()
    assert 'model = "models/m25.npz"' in text  # relative: the directory moves as a whole
    fam = load_model(man)
    assert isinstance(fam, FillFamily)
    np.testing.assert_array_equal(fam.fills_, [0.25, 0.5, 0.75])
    u, _ = smooth_io(300, 4)
    np.testing.assert_array_equal(fam.at(0.4).simulate(u),
                                  FillFamily.from_members(members).at(0.4).simulate(u))

    def bad(body, match):
        p = tmp_path / "bad.toml"
        p.write_text(body)
        with pytest.raises(ModelFileError, match=match):
            load_model(p)

    head = "[fill_family]\nformat_version = 1\n"
    bad("[other]\n", r"no \[fill_family\] table")
    bad("[fill_family]\nformat_version = 2\n", "format_version must be 1")
    bad(head, "no \\[\\[fill_family.member\\]\\]")
    bad(head + '[[fill_family.member]]\nfill = 0.25\nmodel = "models/nope.npz"\n',
        "member 1: model file .*nope.npz not found")
    bad(head + '[[fill_family.member]]\nfill = 1.5\nmodel = "models/m25.npz"\n',
        r"member 1: fill must be in \(0, 1\)")
    bad(head + '[[fill_family.member]]\nfill = "a"\nmodel = "models/m25.npz"\n',
        "member 1: fill must be a number")
    bad(head + '[[fill_family.member]]\nfill = 0.25\nmodel = "family.toml"\n',
        "is a family file")
    bad(head + '[[fill_family.member]]\nfill = 0.25\n', "exactly the keys fill and model")
    bad("not = toml = at all", "not a valid TOML")
    # a member whose own fill disagrees with the manifest
    bad(head + '[[fill_family.member]]\nfill = 0.3\nmodel = "models/m25.npz"\n'
        '[[fill_family.member]]\nfill = 0.5\nmodel = "models/m50.npz"\n',
        "member at fill 30.0%")
    with pytest.raises(ROMError, match="must end in .toml"):
        write_family(tmp_path / "f.txt", paths)
    assert read_family(man, load_model).fill_range == (0.25, 0.75)


def _records(tmp_path, fills):
    paths = []
    for (name, seed, n), fill in zip((("train", 1, 2000), ("validation", 2, 600)), fills,
                                     strict=True):
        u, y = smooth_io(n, seed)
        attrs = {} if fill is None else {"fill": fill}
        rec = Record(np.arange(n) / FS, FS, {"velocity": u, "dynamic_force": y},
                     {"velocity": "m/s", "dynamic_force": "N"}, attrs)
        paths.append(write_record(rec, tmp_path / f"{name}_{fill}.nc"))
    return paths


def _train(paths, out, *extra):
    return CliRunner().invoke(app, [
        "train", "--data", str(paths[0]), "--validation", str(paths[1]), "--out", str(out),
        "--delays", "3", "--neurons", "4", "--max-epochs", "2", "--trainer", "fast", *extra])


def test_cli_train_records_the_fill_of_the_records(tmp_path):
    res = _train(_records(tmp_path, (0.25, 0.25)), tmp_path / "a.npz")
    assert res.exit_code == 0, res.output
    assert training_fills(load_model(tmp_path / "a.npz")) == (0.25, 0.25)
    # --fill for records that do not say it
    res = _train(_records(tmp_path, (None, None)), tmp_path / "b.npz", "--fill", "0.6")
    assert res.exit_code == 0, res.output
    assert training_fills(load_model(tmp_path / "b.npz")) == (0.6, 0.6)
    # and nothing recorded when neither says it
    res = _train(_records(tmp_path, (None, None)), tmp_path / "c.npz")
    assert res.exit_code == 0 and training_fills(load_model(tmp_path / "c.npz")) is None


@pytest.mark.parametrize("fills, extra, match", [
    ((0.25, 0.5), (), "taken at different fills"),
    ((0.25, 0.25), ("--fill", "0.5"), "--fill 0.5 but .* was taken at fill 0.25"),
    ((None, None), ("--fill", "1.5"), "--fill"),
])
def test_cli_train_refuses_inconsistent_fills(tmp_path, fills, extra, match):
    res = _train(_records(tmp_path, fills), tmp_path / "m.npz", *extra)
    assert res.exit_code == 2 and re.search(match, res.output), res.output
    assert not (tmp_path / "m.npz").exists()


def test_cli_map_and_beam_take_the_fill(tmp_path, members):
    paths = {f: m.save(tmp_path / f"m{int(f * 100)}.npz") for f, m in members.items()}
    fam = write_family(tmp_path / "family.toml", paths)
    runner = CliRunner()
    # a single ROM refuses another fill, before any work, and writes nothing
    res = runner.invoke(app, ["map", "--model", str(paths[0.25]), "--fill", "0.5",
                              "--n-omega", "2", "--n-a", "2", "--out", str(tmp_path / "x.nc")])
    assert res.exit_code == 2 and "identified at fill 25.0%; fill 50.0%" in res.output
    assert not (tmp_path / "x.nc").exists()
    # a family needs a fill
    res = runner.invoke(app, ["map", "--model", str(fam), "--n-omega", "2", "--n-a", "2",
                              "--out", str(tmp_path / "x.nc")])
    assert res.exit_code == 2 and "give the fill level" in res.output
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        res = runner.invoke(app, ["map", "--model", str(fam), "--fill", "0.4", "--n-omega",
                                  "2", "--n-a", "2", "--out", str(tmp_path / "f.nc")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "f.nc").is_file()
    res = runner.invoke(app, ["beam", "free", "--sloshing", str(paths[0.75]), "--out",
                              str(tmp_path / "beam"), "--duration", "2"])
    assert res.exit_code == 2 and "identified at fill 75.0%; fill 50.0%" in res.output
    assert "--fill" in res.output
    res = runner.invoke(app, ["beam", "free", "--sloshing", str(fam), "--fill", "0.8",
                              "--out", str(tmp_path / "beam"), "--duration", "2"])
    assert res.exit_code == 2 and "25.0% to 75.0%; fill 80.0%" in res.output


def test_cli_predict_and_export_with_a_family(tmp_path, members):
    paths = {f: m.save(tmp_path / f"m{int(f * 100)}.npz") for f, m in members.items()}
    fam = write_family(tmp_path / "family.toml", paths)
    rec_none, rec_fill = _records(tmp_path, (None, 0.4))
    runner = CliRunner()
    res = runner.invoke(app, ["predict", "--model", str(fam), "--data", str(rec_none),
                              "--out", str(tmp_path / "p.nc")])
    assert res.exit_code == 2 and "give the fill level" in res.output
    # the record's fill attribute picks the blend
    res = runner.invoke(app, ["predict", "--model", str(fam), "--data", str(rec_fill),
                              "--out", str(tmp_path / "p.nc")])
    assert res.exit_code == 0, res.output
    u = read_record(rec_fill)["velocity"]
    np.testing.assert_allclose(read_record(tmp_path / "p.nc")["dynamic_force_pred"],
                               FillFamily.from_members(members).at(0.4).simulate(u),
                               rtol=1e-12, atol=1e-12)
    res = runner.invoke(app, ["predict", "--model", str(paths[0.25]), "--data", str(rec_fill),
                              "--out", str(tmp_path / "q.nc")])
    assert res.exit_code == 2 and "identified at fill 25.0%; fill 40.0%" in res.output
    res = runner.invoke(app, ["export", "onnx", str(fam), str(tmp_path / "f.onnx")])
    assert res.exit_code == 2 and "FillFamily cannot be exported" in res.output


def test_load_model_at_a_fill_gives_a_sloshing_model(tmp_path, members):
    paths = {f: m.save(tmp_path / f"m{int(f * 100)}.npz") for f, m in members.items()}
    fam = write_family(tmp_path / "family.toml", paths)
    family = load_model(fam)
    # a family describes its records as its members do, without being a sloshing model
    assert isinstance(family, FillFamily) and not isinstance(family, SloshingModel)
    assert (family.names, family.units, family.input) == \
        (tuple(members[0.25].names), tuple(members[0.25].units), "velocity")
    blend = load_model(fam, fill=0.4)
    assert isinstance(blend, SloshingModel) and blend.fill == 0.4
    u = np.linspace(-0.1, 0.1, 50)
    np.testing.assert_array_equal(blend.simulate(u, None),
                                  FillFamily.from_members(members).at(0.4).simulate(u, None))
    single = load_model(paths[0.25], fill=0.25)
    assert type(single) is type(members[0.25])
    with pytest.raises(FillRangeError, match="identified at fill 25.0%; fill 40.0%"):
        load_model(paths[0.25], fill=0.4)
