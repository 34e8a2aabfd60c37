"""Honest comparison of Phi_d maps: the whole map, the dissipative region and the passivity
(``sloshrom.energy.map_fidelity``), the figures that show them, the report text and
``sloshrom map --reference``."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import TwoSlopeNorm, to_rgb
from matplotlib.contour import ContourSet
from typer.testing import CliRunner

from sloshrom.energy import map_fidelity
from sloshrom.pipeline.maps import fidelity_lines, relative_map_error
from sloshrom.pipeline.report import _fidelity_text
from sloshrom.plotting.maps import NEGATIVE_COLOR, phi_d_map_figure, plot_phi_d_map

# reference (rig) and other (ROM) on a 2 x 3 grid; the reference is NaN at [1, 2] (outside the
# shaker envelope), where the other map has a value that must not count
REF = np.array([[2.0, 1.0, 0.1],
                [0.0, 0.0, np.nan]])
OTHER = np.array([[2.0, 0.0, 0.1],
                  [-0.5, 0.03, 1.0]])
OB = np.array([2.0, 3.0])
AB = np.array([0.1, 0.2, 0.3])


def _da(values: np.ndarray, ob: np.ndarray = OB, ab: np.ndarray = AB) -> xr.DataArray:
    return xr.DataArray(values, dims=("omega_bar", "a_bar"),
                        coords={"omega_bar": ob, "a_bar": ab}, name="phi_d")


def test_map_fidelity_by_hand():
    f = map_fidelity(REF, OTHER)
    # 5 points where both are finite; differences 0, -1, 0, -0.5, 0.03
    assert f["n_points"] == 5
    assert f["full_l2"] == pytest.approx(math.sqrt((1 + 0.25 + 0.03**2) / (4 + 1 + 0.01)))
    # dissipative region: REF > 0.1 * 2 -> the points 2.0 and 1.0
    assert f["n_dissipative"] == 2
    assert f["dissipative_l2"] == pytest.approx(1 / math.sqrt(5))
    # passivity threshold -0.02 * 2: only -0.5 is below it (0.03 and 0.0 are not)
    assert f["passivity_threshold"] == pytest.approx(-0.04)
    assert f["n_nonpassive"] == 1 and f["nonpassive_fraction"] == pytest.approx(0.2)
    assert f["min_phi_d"] == -0.5
    assert f["reference_maximum"] == 2.0 and f["dissipative_level"] == pytest.approx(0.2)
    # plain arrays carry no grid
    assert math.isnan(f["min_omega_bar"]) and math.isnan(f["min_a_bar"])
    # plain Python numbers (summary.json)
    assert all(type(v) in (int, float) for v in f.values())
    assert isinstance(f["n_points"], int) and isinstance(f["full_l2"], float)


def test_map_fidelity_locates_the_minimum_on_dataarrays_in_any_dim_order():
    f = map_fidelity(_da(REF), _da(OTHER))
    assert (f["min_omega_bar"], f["min_a_bar"]) == (3.0, 0.1)
    g = map_fidelity(_da(REF), _da(OTHER).transpose("a_bar", "omega_bar"))
    assert g == f
    # coordinates from the reference when the other map is a plain array
    h = map_fidelity(_da(REF), OTHER)
    assert (h["min_omega_bar"], h["min_a_bar"]) == (3.0, 0.1)


def test_map_fidelity_nan_in_other_and_noise_level_negatives():
    other = OTHER.copy()
    other[0, 1] = np.nan  # the ROM map misses a point of the rig's: not compared either
    other[1, 0] = -0.01  # round-off level: above the -0.04 threshold
    f = map_fidelity(REF, other)
    assert f["n_points"] == 4 and f["n_dissipative"] == 1
    assert f["dissipative_l2"] == 0.0
    assert f["full_l2"] == pytest.approx(math.sqrt((0.01**2 + 0.03**2) / (4 + 0.01)))
    assert f["n_nonpassive"] == 0 and f["nonpassive_fraction"] == 0.0
    assert f["min_phi_d"] == -0.01


def test_map_fidelity_degenerate_maps():
    # a reference that dissipates nowhere: no region, no relative error, any negative counts
    f = map_fidelity(np.zeros((2, 2)), np.array([[0.0, -1e-6], [0.5, 0.0]]))
    assert f["n_dissipative"] == 0 and math.isnan(f["dissipative_l2"])
    assert math.isnan(f["full_l2"])
    assert f["passivity_threshold"] == 0.0 and f["n_nonpassive"] == 1
    # nothing in common
    g = map_fidelity(np.full((2, 2), np.nan), np.ones((2, 2)))
    assert g["n_points"] == 0 and g["n_nonpassive"] == 0
    assert all(math.isnan(g[k]) for k in ("full_l2", "dissipative_l2", "nonpassive_fraction",
                                          "min_phi_d"))


def test_map_fidelity_rejects_mismatched_maps():
    with pytest.raises(ValueError, match="shape"):
        map_fidelity(REF, OTHER[:, :2])
    with pytest.raises(ValueError, match="omega_bar"):
        map_fidelity(_da(REF), _da(OTHER, ob=OB * 1.1))
    with pytest.raises(ValueError, match="passivity_tolerance"):
        map_fidelity(REF, OTHER, passivity_tolerance=-0.1)


def test_relative_map_error_is_the_dissipative_figure():
    assert relative_map_error(REF, OTHER) == pytest.approx(1 / math.sqrt(5))
    # threshold 0: every point with a positive reference (2.0, 1.0, 0.1)
    assert relative_map_error(REF, OTHER, threshold=0.0) == pytest.approx(1 / math.sqrt(5.01))


def test_fidelity_lines_whole_map_first():
    text = "\n".join(fidelity_lines(map_fidelity(_da(REF), _da(OTHER)), "rig.nc"))
    full, diss, pas = (text.index(k) for k in ("full map", "dissipative region", "passivity"))
    assert full < diss < pas
    assert f"{math.sqrt(1.2509 / 5.01):.1%}" in text and f"{1 / math.sqrt(5):.1%}" in text
    assert "1 points (20.0%)" in text and "-0.04" in text and "min Phi_d = -0.5" in text
    assert "omega_bar = 3.00, a_bar = 0.100" in text


def test_report_states_full_then_dissipative_then_passivity():
    fid = map_fidelity(_da(REF), _da(OTHER))
    html = _fidelity_text({"rom_relative_l2_error": fid["dissipative_l2"], "rom_fidelity": fid})
    order = [html.index(k) for k in ("full map", "dissipative region", "passivity")]
    assert order == sorted(order)
    assert f"{fid['full_l2']:.1%}" in html and f"{fid['dissipative_l2']:.1%}" in html
    assert "20.0%" in html and "-0.04" in html and "-0.5" in html
    # a summary of an older maps stage still gives its one figure, and says what is missing
    old = _fidelity_text({"rom_relative_l2_error": 0.25})
    assert "25.0%" in old and "rerun" in old


def _contour_set(ax) -> ContourSet:
    (cs,) = [c for c in ax.collections if isinstance(c, ContourSet) and c.filled]
    return cs


def test_difference_figure_is_centred_on_zero():
    ob = np.linspace(2.0, 6.0, 9)
    ab = np.linspace(0.05, 0.4, 8)
    z = np.linspace(-0.1, 0.4, ob.size)[:, None] * np.ones(ab.size)  # asymmetric range
    fig = phi_d_map_figure(_da(z, ob, ab), "ROM minus rig", kind="difference")
    cs = _contour_set(fig.axes[0])
    assert isinstance(cs.norm, TwoSlopeNorm) and cs.norm.vcenter == 0.0
    assert cs.norm.vmin == pytest.approx(-0.4) and cs.norm.vmax == pytest.approx(0.4)
    assert cs.cmap.name == "RdBu_r"
    # white at zero, red above, blue below
    r0, g0, b0, _ = cs.cmap(cs.norm(0.0))
    assert min(r0, g0, b0) > 0.9
    r, _, b, _ = cs.cmap(cs.norm(0.3))
    assert r > b
    r, _, b, _ = cs.cmap(cs.norm(-0.3))
    assert b > r
    with pytest.raises(ValueError, match="kind"):
        phi_d_map_figure(_da(z, ob, ab), "x", kind="diff")


def _pixel(fig, ax, x: float, y: float) -> np.ndarray:
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    img = np.asarray(canvas.buffer_rgba())
    px, py = ax.transData.transform((x, y))
    return img[int(round(img.shape[0] - py)), int(round(px)), :3] / 255.0


def _three_regions(low: float) -> xr.DataArray:
    """Phi_d = -0.5 for omega_bar < 2, ``low`` for 2.2..3, 1.0 from 3.2 (a ramp between)."""
    ob = np.linspace(1.0, 5.0, 41)
    ab = np.linspace(0.01, 0.45, 23)
    col = np.interp(ob, [1.0, 2.0, 2.2, 3.0, 3.2, 5.0], [-0.5, -0.5, low, low, 1.0, 1.0])
    return _da(col[:, None] * np.ones(ab.size), ob, ab)


def test_map_figure_paints_negative_values_apart_from_zero():
    fig = phi_d_map_figure(_three_regions(0.0), "ROM")
    ax = fig.axes[0]
    cs = _contour_set(ax)
    negative = _pixel(fig, ax, 1.4, 0.2)
    zero = _pixel(fig, ax, 2.6, 0.25)
    top = _pixel(fig, ax, 4.5, 0.1)
    np.testing.assert_allclose(negative, to_rgb(NEGATIVE_COLOR), atol=0.02)
    # zero has the colour of the lowest band of the scale (band 0 is the "under" one)
    bands = cs.get_facecolor()[:, :3]
    np.testing.assert_allclose(bands[0], to_rgb(NEGATIVE_COLOR), atol=1e-6)
    np.testing.assert_allclose(zero, bands[1], atol=0.02)
    assert np.abs(negative - zero).max() > 0.3 and np.abs(top - zero).max() > 0.3
    # the legend names the colour of the non-passive points
    assert any("not passive" in t.get_text() for t in ax.get_legend().get_texts())
    # round-off below zero (1e-4 of the maximum) keeps the colour of zero ...
    fig2 = phi_d_map_figure(_three_regions(-1e-4), "rig")
    np.testing.assert_allclose(_pixel(fig2, fig2.axes[0], 2.6, 0.25), zero, atol=0.02)
    # ... unless the caller sets the threshold to 0
    fig3 = phi_d_map_figure(_three_regions(-1e-4), "rig", negative_below=0.0)
    np.testing.assert_allclose(_pixel(fig3, fig3.axes[0], 2.6, 0.25), to_rgb(NEGATIVE_COLOR),
                               atol=0.02)
    with pytest.raises(ValueError, match="negative_below"):
        plot_phi_d_map(_three_regions(0.0), negative_below=0.1)


def test_map_figure_of_a_zero_map_draws():
    ax = plot_phi_d_map(_da(np.zeros((2, 3))))
    FigureCanvasAgg(ax.figure).draw()
    # a colour scale of zero width would divide by zero: it is widened to a finite one
    lo, hi = ax.collections[0].get_clim()
    assert np.isfinite([lo, hi]).all() and lo < hi


def test_cli_map_reference_prints_the_whole_picture(tmp_path):
    from sloshrom.cli import app
    from sloshrom.config import Tank
    from sloshrom.pipeline import settings
    from sloshrom.pipeline.maps import map_grid
    from sloshrom.rom.tdnn.estimators import NFIR

    rng = np.random.default_rng(0)
    u = np.convolve(rng.standard_normal(600), np.ones(8) / 8, mode="same") * 0.05
    y = np.tanh(20 * np.roll(u, 2)) * 0.5
    NFIR(delays=4, neurons=3, max_epochs=3).fit(u, y, fs=500.0).save(tmp_path / "rom.npz")
    cfg = settings.load().replace(map={"n_omega": 3, "n_a": 2})
    ob, ab = map_grid(cfg, Tank())
    ref = np.array([[0.1, 0.4], [0.2, 0.3], [0.0, 0.05]])
    _da(ref, ob, ab).to_dataset().to_netcdf(tmp_path / "ref.nc", engine="h5netcdf")
    out = tmp_path / "rom_map.nc"
    res = CliRunner().invoke(app, ["map", "--model", str(tmp_path / "rom.npz"), "--reference",
                                   str(tmp_path / "ref.nc"), "--n-omega", "3", "--n-a", "2",
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert out.is_file() and out.with_suffix(".png").is_file()
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        mine = ds["phi_d"].load()
    f = map_fidelity(ref, mine)
    assert f["n_points"] > 0
    text = res.output
    full = re.search(r"full map: +relative L2 error (\S+)", text)
    diss = re.search(r"dissipative region: +relative L2 error (\S+)", text)
    pas = re.search(r"passivity: +(\d+) points", text)
    assert full and diss and pas and full.start() < diss.start() < pas.start()
    assert full.group(1) == f"{f['full_l2']:.1%}"
    assert diss.group(1) == f"{f['dissipative_l2']:.1%}"
    assert int(pas.group(1)) == f["n_nonpassive"]
    assert f"min Phi_d = {f['min_phi_d']:.3g}" in text
