"""Training that covers its use: the VFA designed from the beam tests, the envelope coverage of
coupled runs, and the ``[rig]`` physics overrides."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from helpers import LinearDamper
from sloshrom import ConfigError, signals
from sloshrom.beam.results import to_dataset
from sloshrom.beam.simulation.cases import envelope_table
from sloshrom.beam.simulation.coupled import CoupledSimulator, free_response, random_response
from sloshrom.beam.simulation.envelope import envelope_coverage, frozen_tank_motion, run_motion
from sloshrom.beam.simulation.structure import ModalModel
from sloshrom.config import G, Tank
from sloshrom.models import FrozenLiquid
from sloshrom.pipeline import Context, settings

FS = 500.0
EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"


@pytest.fixture(scope="module")
def modal():
    return ModalModel.from_beam(n_modes=2, damping=[0.01, 0.005])


class EnvelopedDamper(LinearDamper):
    """A jax-traceable viscous damper with a training envelope (stand-in for a ROM)."""

    def __init__(self, envelope, dt=1.0 / FS, c=0.5):
        super().__init__(c, dt)
        self.envelope_ = envelope


# -- design ----------------------------------------------------------------------------------------
def test_frozen_tank_motion_is_the_direct_frozen_simulation(modal):
    tank = Tank()
    tests = {
        "free": lambda m, fs: free_response(m, modal, 0.01, 2.0, tank, fs),
        "random": lambda m, fs: random_response(m, modal, [0.1, 0.3], 8.0, 3, 12.0, 4.0,
                                                signal_fs=FS, tank=tank, output_fs=fs),
    }
    motion = frozen_tank_motion(tests, FS)
    frozen = FrozenLiquid(1.0 / FS)
    free = CoupledSimulator(frozen, modal, tank).run(np.zeros(1000),
                                                     q0=modal.static_tip_state(0.01))
    rand = random_response(frozen, modal, [0.1, 0.3], 8.0, 3, 12.0, 4.0, signal_fs=FS, tank=tank)
    peaks_acc = [np.max(np.abs(free["tank_acceleration"]))] + list(
        np.max(np.abs(rand["tank_acceleration"]), axis=-1))
    peaks_vel = [np.max(np.abs(free["tank_velocity"]))] + list(
        np.max(np.abs(rand["tank_velocity"]), axis=-1))
    assert [r.run for r in motion.runs] == ["free", "random 0.1 g", "random 0.3 g"]
    np.testing.assert_allclose([r.peak_acceleration for r in motion.runs], peaks_acc, rtol=1e-12)
    np.testing.assert_allclose([r.peak_velocity for r in motion.runs], peaks_vel, rtol=1e-12)
    assert motion.peak_acceleration == pytest.approx(max(peaks_acc), rel=1e-12)
    assert motion.peak_velocity == pytest.approx(max(peaks_vel), rel=1e-12)
    # the tank moves at the first frozen mode, and the free response starts from 1 cm
    from sloshrom.beam.simulation.structure import coupled_frozen_modes

    f1 = coupled_frozen_modes(modal, tank.liquid_mass)[0][0]
    assert motion.frequency == pytest.approx(f1, rel=0.05)
    assert motion.runs[0].peak_displacement == pytest.approx(0.01, rel=0.1)


def test_run_motion_of_a_sine():
    fs, f, amp = 500.0, 10.0, 0.02
    t = np.arange(int(4 * fs)) / fs
    om = 2 * np.pi * f
    m = run_motion("sine", -amp * om**2 * np.cos(om * t), -amp * om * np.sin(om * t), fs)
    assert m.frequency == pytest.approx(f)
    assert m.peak_acceleration == pytest.approx(amp * om**2, rel=5e-3)  # sampled peaks
    assert m.peak_velocity == pytest.approx(amp * om, rel=5e-3)
    assert m.peak_displacement == pytest.approx(amp, rel=5e-3)


@pytest.mark.parametrize("split", ["train", "validation"])
def test_vfa_from_a_design_covers_the_structure(split):
    tank = Tank()
    peak_acc, peak_vel, disp, f = 14.5 * G, 2.7, 0.039, 10.2
    d = signals.vfa_design(peak_acc, peak_vel, disp, f, tank, margin=1.15)
    assert d.rule == "structure" and d.exceeds() == ["acceleration", "velocity", "displacement"]
    v = signals.vfa(400.0, split, 120.0, tank, seed=1, **d.kwargs())
    assert np.max(np.abs(v.acceleration)) >= 1.1 * peak_acc
    assert np.max(np.abs(v.velocity)) >= 1.1 * peak_vel
    # ... and at the structure's frequency: the velocity peak of the path lies near f
    k = np.argmax(np.abs(v.velocity))
    assert f / 1.5 < v.frequency[k] < f * 1.2


def test_small_structure_keeps_the_paper_shaker():
    d = signals.vfa_design(1.0 * G, 0.1, 0.001, 10.0, Tank(), margin=1.15)
    assert d.exceeds() == []
    assert d.gamma_max == pytest.approx(signals.SHAKER_ENVELOPE.gamma_max, rel=0.1)
    assert signals.SHAKER_DESIGN.exceeds() == []


@pytest.mark.parametrize("kw", [{"margin": 0.9}, {"peak_acceleration": float("nan")},
                                {"spread": 1.0}, {"frequency": -1.0}])
def test_design_rejects_bad_input(kw):
    args = {"peak_acceleration": 50.0, "peak_velocity": 1.0, "displacement": 0.01,
            "frequency": 10.0, **kw}
    with pytest.raises(ValueError):
        signals.vfa_design(**args)


# -- envelope coverage -----------------------------------------------------------------------------
def test_envelope_coverage_inside_and_outside():
    t = np.arange(1000) / FS
    v = 0.5 * np.sin(2 * np.pi * 10 * t)
    a = 0.5 * 2 * np.pi * 10 * np.cos(2 * np.pi * 10 * t)
    env = {"input_min": -1.0, "input_max": 1.0, "acceleration_max": 100.0}
    inside = envelope_coverage(env, v, a)
    assert inside.outside_fraction == 0.0 and inside.acceleration_ratio < 1
    out = envelope_coverage(env, 2.5 * v, 2.5 * a)  # |v| > 1 where |sin| > 0.8: 41 %
    assert out.outside_fraction == pytest.approx(1 - 2 / np.pi * np.arcsin(0.8), abs=0.01)
    assert out.acceleration_ratio == pytest.approx(2.5 * 0.5 * 2 * np.pi * 10 / 100, rel=1e-3)
    # acceleration alone: velocity inside, acceleration above the training peak
    assert envelope_coverage({**env, "acceleration_max": 10.0}, v, a).outside_fraction > 0
    # an old envelope (no acceleration_max): velocity only, ratio unknown
    old = envelope_coverage({"input_min": -1.0, "input_max": 1.0}, v, 3 * a)
    assert old.outside_fraction == 0.0 and np.isnan(old.acceleration_ratio)
    none = envelope_coverage(None, v, a)
    assert np.isnan(none.outside_fraction) and none.peak_acceleration == pytest.approx(
        np.max(np.abs(a)))
    batch = envelope_coverage(env, np.stack([v, 2.5 * v]), np.stack([a, 2.5 * a]))
    assert batch.outside_fraction.shape == (2,) and batch.outside_fraction[0] == 0 < \
        batch.outside_fraction[1]


def test_coupled_runs_report_their_coverage(modal, tmp_path):
    tank = Tank()
    env = {"input_min": -0.3, "input_max": 0.3, "acceleration_max": 30.0}
    model = EnvelopedDamper(env)
    small = free_response(model, modal, 0.001, 1.0, tank)
    assert small["envelope_outside_fraction"] == 0.0
    with pytest.warns(UserWarning, match="training envelope"):
        big = random_response(model, modal, [0.05, 0.5], 4.0, 0, 12.0, 4.0, tank=tank)
    frac = big["envelope_outside_fraction"]
    assert frac.shape == (2,) and frac[1] > frac[0] >= 0 and frac[1] > 0
    assert big["training_peak_acceleration"] == 30.0
    np.testing.assert_allclose(big["envelope_acceleration_ratio"],
                               np.max(np.abs(big["tank_acceleration"]), axis=-1) / 30.0)
    frozen = free_response(FrozenLiquid(1.0 / FS), modal, 0.001, 1.0, tank)
    assert np.isnan(frozen["envelope_outside_fraction"])
    # the result files and the table carry it; n/a (None) without an envelope
    ds = to_dataset(big, "rom", "random", tank, modal)
    np.testing.assert_allclose(ds["envelope_outside_fraction"].values, frac)
    assert ds.attrs["training_peak_acceleration"] == 30.0
    p = tmp_path / "r.nc"
    ds.to_netcdf(p, engine="h5netcdf")
    with xr.open_dataset(p, engine="h5netcdf") as back:
        assert back["envelope_acceleration_ratio"].dims == ("level",)
    rows = envelope_table({"free": {"rom": small, "frozen": frozen}, "random": {"rom": big}})
    assert [(r["run"], r["case"]) for r in rows] == [
        ("free", "rom"), ("free", "frozen"), ("random 0.05 g", "rom"), ("random 0.5 g", "rom")]
    assert rows[1]["outside_fraction"] is None and rows[1]["training_peak_acceleration_g"] is None
    assert rows[3]["outside_fraction"] == pytest.approx(frac[1])
    assert rows[0]["training_peak_acceleration_g"] == pytest.approx(30.0 / G)


# -- [rig] overrides -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "rig, match",
    [({"restitution": 1.0}, r"'rig\.restitution' must be a coefficient of restitution in \[0, 1\)"),
     ({"restitution": -0.1}, r"'rig\.restitution'"),
     ({"beta": 0.0}, r"'rig\.beta' must be a fraction of the liquid mass in \(0, 1\]"),
     ({"beta": 1.2}, r"'rig\.beta'"),
     ({"beta": True}, r"'rig\.beta'"),
     ({"n_layers": 3}, r"unknown configuration key 'rig\.n_layers'")],
)
def test_bad_rig_overrides(rig, match):
    with pytest.raises(ConfigError, match=match):
        settings.validate(settings.merge(settings.defaults(), {"rig": rig}))


def test_rig_overrides_reach_the_rig(tmp_path):
    from sloshrom.rig.params import RigParams

    cfg = settings.load(EXAMPLES / "rig_b.toml")
    assert (cfg.rig.restitution, cfg.rig.beta) == (0.05, 0.7)
    rig = Context(tmp_path, cfg).rig()
    calibrated = RigParams.default()
    assert rig.params == calibrated.replace(restitution=0.05, beta=0.7)
    assert rig.params != calibrated
    # absent keys: the calibrated physics
    assert Context(tmp_path, settings.load()).rig().params == calibrated
    # every other key of the example is the default
    defaults = settings.defaults()
    assert {t: {k: v for k, v in sec.items()
                if t != "rig" or k not in ("restitution", "beta")}
            for t, sec in cfg.as_dict().items()} == defaults


# -- the data stage --------------------------------------------------------------------------------
TINY = {"data": {"train_duration": 12.0, "validation_duration": 12.0,
                 "extension_duration": 20.0, "design": "structure"},
        "beam": {"free_duration": 3.0, "random_duration": 40.0, "rms_g": [0.1, 0.3]}}


def test_data_stage_designs_from_the_structure(tmp_path):
    from sloshrom.io import read_record
    from sloshrom.pipeline.data import stage_data, training_design

    cfg = settings.validate(settings.merge(settings.defaults(), TINY))
    out, files = stage_data(Context(tmp_path, cfg))
    des = out["design"]
    fz = des["frozen_beam_tests"]
    assert des["rule"] == "structure" and [r["run"] for r in fz["runs"]] == [
        "free", "random 0.1 g", "random 0.3 g"]
    # the frozen peaks are those of the configured tests, and the records cover them
    _, motion = training_design(cfg, Tank())
    assert fz["peak_acceleration_g"] == pytest.approx(motion.peak_acceleration / G)
    assert des["gamma_max_g"] >= cfg.data.margin * fz["peak_acceleration_g"]
    assert des["exceeds_shaker"] and "acceleration" in des["exceeds_shaker"]
    # the programme each record played, checked against the paper's shaker (summary.json)
    for split, prog in des["programme"].items():
        assert [g["name"] for g in prog["segments"]] == ["vfa", "vfa extension"], split
        assert "acceleration" in " ".join(prog["exceeds"])
        assert prog["verdict"].startswith("needs a bigger shaker")
    for split in ("train", "validation"):
        rec = read_record(tmp_path / "data" / f"{split}.nc")
        assert np.max(np.abs(rec["acceleration"])) / G == pytest.approx(
            out[split]["max_acceleration_g"])
        assert out[split]["covers_acceleration"] >= 1.05
        assert out[split]["covers_velocity"] >= 1.05
        # the paper's path first (its shaker domain: <= 6 g), then the structure's extension
        ext = 20.0 if split == "train" else 10.0
        fs = rec.fs
        assert len(rec) == round((12.0 + ext) * fs) + 1  # two pieces, one record
        first = np.abs(rec["acceleration"][: round(12.0 * fs) + 1])
        assert np.max(first) / G <= 6.0 * 1.02
        assert np.max(np.abs(rec["acceleration"][round(12.0 * fs) + 1:])) / G >= 1.05 * fz[
            "peak_acceleration_g"]
    assert "data/train.nc" in files


def test_shaker_design_is_the_paper_vfa():
    from sloshrom.pipeline.data import design_outputs, training_design

    cfg = settings.load().replace(data={"design": "shaker"})
    design, motion = training_design(cfg, Tank())
    assert design == signals.SHAKER_DESIGN and motion is None
    out = design_outputs(design, motion)
    assert out["exceeds_shaker"] == [] and out["gamma_max_g"] == 6.0
    assert out["frozen_beam_tests"] is None
