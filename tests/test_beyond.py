"""`reproduce --beyond` mechanics on a tiny configuration: the fill family is identified, mapped
at an unseen fill, run in the beam, reported; the numbers are physical, not accurate."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import xarray as xr

from sloshrom.pipeline import run, settings
from sloshrom.pipeline import study as studies
from sloshrom.pipeline.chain import RESULT_ENTRIES
from sloshrom.pipeline.html import Section
from sloshrom.pipeline.study import Study
from sloshrom.rom.errors import FillRangeError
from sloshrom.rom.family import FillFamily, training_fills
from sloshrom.rom.loading import load_model

pytestmark = pytest.mark.long  # a reproduce --beyond run


def tiny_config(config) -> settings.ReproduceConfig:
    """The session's tiny configuration with the studies beyond the paper switched on."""
    return settings.load(config).replace(beyond={
        "enabled": True, "fills": [0.4, 0.5], "unseen_fills": [0.45], "beam_fills": [0.45],
        "baseline": True, "multimode": False})


@pytest.fixture(scope="module")
def beyond_run(tmp_path_factory, tiny_reproduce):
    """``--beyond`` in a copy of the tiny run: the paper's stages are reused, not redone."""
    out = tmp_path_factory.mktemp("beyond") / "results"
    shutil.copytree(tiny_reproduce["out"], out)
    summary = run(out, tiny_config(tiny_reproduce["config"]))
    return out, summary


def test_paper_stages_are_reused_by_the_beyond_run(beyond_run):
    _, summary = beyond_run
    assert all(summary["stages"][k]["reused"] for k in ("data", "rom", "maps", "beam"))


def test_fill_family_stage(beyond_run):
    out, summary = beyond_run
    f = summary["stages"]["fills"]
    # the member at the [tank] fill is the main ROM; the other was identified at its own fill
    assert f["members"]["50"]["main_rom"] and not f["members"]["40"]["main_rom"]
    fam = load_model(out / f["family"])
    assert isinstance(fam, FillFamily) and fam.fill_range == (0.4, 0.5)
    assert training_fills(fam.members_[0]) == (0.4, 0.4)
    assert training_fills(load_model(out / summary["stages"]["rom"]["model"])) == (0.5, 0.5)
    with pytest.raises(FillRangeError):
        fam.at(0.6)
    rows = {r["fill"]: r for r in f["maps"]}
    assert set(rows) == {0.4, 0.45, 0.5} and rows[0.45]["unseen"] and not rows[0.4]["unseen"]
    assert all(np.isfinite(r["full_l2"]) for r in rows.values())
    ds = xr.open_dataset(out / "fills" / "phi_d_maps.nc")
    np.testing.assert_allclose(ds["fill"], [0.4, 0.45, 0.5])
    # a heavier liquid dissipates more energy, a lower fill more energy per kg: the rig's maps
    # differ between fills
    assert not np.allclose(ds["phi_d_rig"].sel(fill=0.4), ds["phi_d_rig"].sel(fill=0.5),
                           equal_nan=True)
    cases = {r["case"] for r in f["damping"]}
    assert cases == {"rig", "rom", "frozen"}
    frozen = [r for r in f["damping"] if r["case"] == "frozen"]
    # frozen liquid: the dry beam's 1 % first-mode damping (LSCF on 34 s: loose bound)
    assert all(0.004 < r["lscf_h1"] < 0.02 for r in frozen if np.isfinite(r["lscf_h1"]))
    assert [e["unseen"] for e in f["beam_errors"]] == [True]
    for name in ("fills_phi_d_maps", "fills_damping"):
        assert (out / "figures" / f"{name}.png").stat().st_size > 10_000
    html = (out / "report.html").read_text()
    assert "one ROM for every fill level" in html
    assert json.loads((out / "summary.json").read_text())["stages"]["fills"]["unseen_fills"] \
        == [0.45]


def test_bouncing_ball_stage(beyond_run):
    out, summary = beyond_run
    b = summary["stages"]["baseline"]
    ball = load_model(out / "models" / "bouncing_ball.toml")
    assert ball.parameters() == pytest.approx(b["parameters"])
    assert 0 < b["parameters"]["mass_fraction"] <= 1 and b["fit_seconds"] > 0
    assert np.isfinite(b["ball_fidelity"]["full_l2"])
    assert {r["case"] for r in b["table2_all"]} >= {"rig", "rom", "frozen"}
    assert "bouncing" in (out / "report.html").read_text().lower()


def test_rerun_reuses_the_members(beyond_run, tiny_reproduce):
    out, _ = beyond_run
    again = run(out, tiny_config(tiny_reproduce["config"]))
    assert again["stages"]["fills"]["reused"] and again["stages"]["baseline"]["reused"]


# -- the registry ----------------------------------------------------------------------------------
def test_the_registry_declares_the_three_studies():
    reg = studies.registered()
    assert [s.name for s in reg] == ["baseline", "fills", "multimode"]  # the report's order
    assert {d for s in reg for d in s.directories} == {"fills/", "multimode/"}
    assert set(RESULT_ENTRIES) >= {"fills/", "multimode/"}
    off = settings.load()
    assert not any(s.enabled(off) for s in reg)  # [beyond] is off by default
    on = off.replace(beyond={"enabled": True, "baseline": False})
    assert [s.name for s in reg if s.enabled(on)] == ["fills", "multimode"]


@pytest.mark.parametrize("bad", [{"name": "beam"}, {"after": ("sweep",)},
                                 {"directories": ("toy",)}])
def test_a_study_declaration_is_checked(bad):
    kw = {"name": "toy", "enabled": bool, "cache_config": dict, "after": (),
          "run": lambda ctx, up, identify: ({}, []), "section": lambda ctx, o: None}
    with pytest.raises(TypeError):
        Study(**{**kw, **bad})


def test_a_fourth_study_runs_from_its_declaration_alone(tmp_path, tiny_reproduce, monkeypatch):
    """A study the pipeline has never heard of: registered, it runs as a cached stage after the
    paper's (their results at hand), its section is in the report, a rerun reuses it."""
    seen = {}

    def toy_run(ctx, upstream, identify):
        seen["upstream"] = sorted(upstream)
        path = ctx.path("toy", "note.txt")
        path.write_text(upstream["rom"].outputs["model"])
        return {"model": upstream["rom"].outputs["model"]}, [ctx.rel(path)]

    toy = Study(name="toy", enabled=lambda cfg: True, cache_config=lambda cfg: {"n": 1},
                after=("rom", "beam"), run=toy_run,
                section=lambda ctx, o: Section("Toy study", f"<p>toy of {o['model']}</p>"),
                directories=("toy/",))
    real = studies.registered()
    monkeypatch.setattr(studies, "registered", lambda: (*real, toy))
    out = tmp_path / "results"
    shutil.copytree(tiny_reproduce["out"], out)
    cfg = settings.load(tiny_reproduce["config"])
    summary = run(out, cfg)
    assert seen["upstream"] == ["beam", "rom"]
    assert summary["stages"]["toy"]["model"] == summary["stages"]["rom"]["model"]
    assert not summary["stages"]["toy"]["reused"] and "toy" in summary["timings_s"]
    assert (out / "toy" / "note.txt").read_text() == summary["stages"]["rom"]["model"]
    assert "Toy study" in (out / "report.html").read_text()
    again = run(out, cfg)
    assert again["stages"]["toy"]["reused"]
