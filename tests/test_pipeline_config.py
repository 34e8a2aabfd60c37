"""The reproduce pipeline follows its configuration: sweep (Fig. 8), record rate, tank and beam."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from sloshrom.cli import app
from sloshrom.config import Tank
from sloshrom.pipeline import Context, settings
from sloshrom.pipeline.data import stage_data

# the default data design (the VFA extended to the beam tests' motion), three RMS levels and a
# two-member ensemble: what tests/test_pipeline.py's tiny configuration leaves out
SMALL = """
[data]
train_duration = 30.0
validation_duration = 15.0
[rom]
arch = "nfir"
delays = 6
neurons = 3
max_epochs = 4
sweep_nfir_delays = [4, 6]
sweep_nfir_neurons = [2]
sweep_noe_delays = [2]
sweep_noe_neurons = [2]
sweep_workers = 1
[map]
n_omega = 3
n_a = 3
[beam]
free_duration = 4.0
random_duration = 70.0
"""


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::UserWarning")
def test_reproduce_sweep_writes_fig8_and_is_cached(tmp_path):
    """Sweep first, then without it (the fast tier: tests/test_pipeline.py, the other order)."""
    cfg_file = tmp_path / "tiny.toml"
    cfg_file.write_text(SMALL)
    out = tmp_path / "res"
    res = CliRunner().invoke(app, ["reproduce", "--sweep", "--config", str(cfg_file),
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    sw = s["stages"]["sweep"]
    assert len(sw["sweep_rows"]) == 3  # nfir d4 n2, nfir d6 n2, noe d2 n2
    assert {(r[0], r[1], r[2]) for r in sw["sweep_rows"]} == {("NFIR", 4, 2), ("NFIR", 6, 2),
                                                             ("NOE", 2, 2)}
    table = json.loads((out / "sweep" / "sweep.json").read_text())
    assert sorted(t["name"] for t in table) == ["nfir_d4_n2", "nfir_d6_n2", "noe_d2_n2"]
    assert (out / "figures" / "fig08_sensitivity.png").stat().st_size > 10_000
    html = (out / "report.html").read_text()
    assert "Fig. 8" in html and "Sensitivity analysis over 3 networks" in html
    # the sweep is its own stage: the ROM of the report is the configured one, and switching
    # the sweep off again reuses the trained ROM instead of training it again
    res = CliRunner().invoke(app, ["reproduce", "--config", str(cfg_file), "--out", str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert "sweep" not in s["stages"] and s["stages"]["rom"]["reused"]
    assert "The sensitivity sweep was not run" in (out / "report.html").read_text()


def test_rig_fs_is_the_record_rate(tmp_path):
    # the paper's VFA only: the structure's extension (4 min of rig time) changes no rate
    cfg = settings.merge(settings.defaults(), {
        "rig": {"fs": 1000.0},
        "data": {"train_duration": 12.0, "validation_duration": 12.0, "design": "shaker"}})
    ctx = Context(tmp_path, cfg)
    assert ctx.rig().sensors.output_fs == 1000.0
    outputs, files = stage_data(ctx)
    from sloshrom.io import read_record

    for split in ("train", "validation"):
        rec = read_record(tmp_path / "data" / f"{split}.nc")
        assert rec.fs == pytest.approx(1000.0) and outputs[split]["fs_hz"] == pytest.approx(1000.0)


def test_report_setup_follows_the_configuration():
    from sloshrom.pipeline.report import _setup_section

    cfg = settings.load().replace(
        tank={"length": 0.2, "width": 0.1}, beam={"length": 0.5, "thickness": 0.008},
        rig={"fs": 1000.0})
    rows = {r[0]: r[1:] for r in _setup_section(cfg).tables[0].rows}
    assert rows["tank inner base l1 × l2"] == ["200.0 × 100.0 mm", "configuration"]
    assert rows["beam length × width × thickness"] == ["0.5 × 0.1 × 0.008 m, clamped",
                                                       "configuration"]
    assert rows["record rate (rig sensors and beam accelerometers)"] == ["1000 Hz",
                                                                         "configuration"]
    assert rows["tank height h"] == ["27.2 mm", "paper"]
    default_rows = {r[0]: r[1:] for r in _setup_section(settings.load()).tables[0].rows}
    assert default_rows["tank inner base l1 × l2"] == ["117.2 × 78.0 mm", "paper"]
    assert default_rows["beam length × width × thickness"] == ["0.74 × 0.1 × 0.01 m, clamped",
                                                               "paper"]


def test_beam_structure_follows_the_configuration():
    from sloshrom.beam.simulation.structure import CantileverBeam
    from sloshrom.pipeline.beam import beam_structure

    # the [beam] table alone: with 'rig.fs' = 500 Hz its mode 3 would lie above Nyquist
    table = settings.BeamTable.model_validate({**settings.defaults()["beam"], "length": 0.5,
                                               "density": 2800.0})
    tank = Tank()
    beam, modal = beam_structure(table, tank)
    ref = CantileverBeam(length=0.5, density=2800.0, tip_mass=tank.structure_mass,
                         tip_inertia=beam.tip_inertia)
    np.testing.assert_allclose(modal.frequencies, ref.frequencies(3), rtol=1e-12)
    np.testing.assert_allclose(modal.stations, [0.1, 0.2, 0.3, 0.4, 0.5])
    # a shorter beam is stiffer: every mode is higher than the paper's beam
    _, paper = beam_structure(settings.load().beam, tank)
    assert np.all(modal.frequencies > paper.frequencies)


def test_recipe_text_names_the_terms_in_use():
    from sloshrom.pipeline.rom import recipe_text

    default = recipe_text({"amplitude_weighting": 0.0, "passivity": 1.0, "cycle_energy": 0.1},
                          "NFIR(70, 35)")
    assert "harmonic probes" in default and "weight 0.1" in default
    assert "1/(a² + ε²)" not in default  # amplitude weighting is off
    paper = recipe_text({"amplitude_weighting": 0.0, "passivity": 0.0, "cycle_energy": 0.0},
                        "NFIR(70, 35)")
    assert "plain MSE" in paper and "physics" not in paper


def test_the_sweep_trains_and_keys_with_the_nfir_table_s_precision():
    # the sweep's NFIRs train as the compared NFIR: [rom.nfir]'s epochs, hidden layer and
    # float32 steps; a change of the precision is a new sweep (its cache key)
    from sloshrom.pipeline.rom import sweep_keys, sweep_options

    cfg = settings.load()
    assert sweep_options(cfg.rom) == {"max_epochs": 90, "hidden": "matlab",
                                      "precision": "float32", "seed": 0}
    keys = sweep_keys(cfg.tables("rom")["rom"])
    assert keys["precision"] == "float32"
    other = settings.config_model().model_validate(
        settings.merge(settings.defaults(), {"rom": {"nfir": {"precision": "float64"}}}))
    assert sweep_keys(other.tables("rom")["rom"])["precision"] == "float64"
