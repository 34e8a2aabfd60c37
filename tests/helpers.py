"""Helpers shared by several test modules (test modules never import each other).

- ``check_cli``: the bad-input contract of a command (exit code 2, one ``error:`` line, nothing
  written, removed or changed);
- ``good_record``, ``make_model_files``: a small shaker record and tiny saved ROMs;
- ``model_parts``/``write_model_parts``: a model file's JSON metadata and arrays, and a
  re-signed file written from edited parts;
- ``LinearDamper``, ``NumpyDamper``, ``NumbaDamper``: stand-in sloshing models for the three
  backends of the coupled simulation;
- ``smooth_io``: a smooth random input and a delayed tanh of it (a small identification case);
- ``TINY_REPRODUCE``, ``reproduce_interrupted_then_resumed``: `sloshrom reproduce` end to end
  at the smallest sizes, stopped before its maps and resumed;
- ``assert_bit_identical``: two results of one machine, to the last bit;
- ``relative_change``, ``perturbation_tolerance``: compare with a stored reference written on
  another CPU, within the change that a relative 1e-13 perturbation of the input makes;
- ``compiled_programs``: the names of the XLA programs compiled inside a block;
- ``TESTS``, ``REPO``: the test folder and the repository, for a test module at any depth of
  ``tests/`` (``tests/beam/...``).
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import jax
import jax.numpy as jnp
import numba as nb
import numpy as np
import pytest
from typer.testing import CliRunner

from sloshrom.cli import app
from sloshrom.io import Record
from sloshrom.rom import modelfile

#: The folder of this module (``tests/``) and the repository: paths that do not depend on
#: where a test module sits below ``tests/``.
TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent

FS_RECORD = 100.0
N_RECORD = 200
runner = CliRunner()


@contextmanager
def compiled_programs() -> Iterator[list[str]]:
    """The names of the XLA programs compiled inside the block (``jit(epoch)``, ...), from
    JAX's compilation log; the list fills as the block runs."""
    names: list[str] = []

    class Handler(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            m = re.match(r"Finished XLA compilation of (\S+)", record.getMessage())
            if m:
                names.append(m.group(1))

    handler = Handler()
    logger = logging.getLogger("jax._src.dispatch")
    logger.addHandler(handler)
    try:
        with jax.log_compiles(True):
            yield names
    finally:
        logger.removeHandler(handler)


def good_record() -> Record:
    """2 s of 5 Hz acceleration and force at 100 Hz (m/s^2, N), fill 0.5."""
    t = np.arange(N_RECORD) / FS_RECORD
    return Record(t, FS_RECORD, {"acceleration": np.sin(2 * np.pi * 5 * t),
                          "force": 0.1 * np.cos(2 * np.pi * 5 * t)},
                  {"acceleration": "m/s^2", "force": "N"}, {"fill": 0.5})


def rig_records() -> tuple[Record, Record]:
    """A short (12 s) virtual-rig VFA training record and a validation-like one (other seed,
    path and noise), preprocessed: velocity (m/s) and dynamic_force (N) at 500 Hz."""
    from sloshrom.io import record_from_measurement
    from sloshrom.rig.virtual import VirtualRig
    from sloshrom.signals import vfa

    out = []
    for seed, split in ((1, "train"), (2, "validation")):
        rig = VirtualRig(seed=seed)
        path = vfa(1.0 / rig.dt, split, duration=12.0, seed=seed)
        out.append(record_from_measurement(rig.measure(path.acceleration)))
    return out[0], out[1]


def make_model_files(d: Path) -> Path:
    """Write good.npz (NFIR, 500 Hz, m/s -> N), newer.npz, tampered.npz and text.npz into d."""
    from sloshrom.rom.tdnn.estimators import NFIR

    rng = np.random.default_rng(0)
    u = np.convolve(rng.standard_normal(600), np.ones(8) / 8, mode="same") * 0.05
    y = np.tanh(20 * np.roll(u, 2)) * 0.5
    good = NFIR(delays=4, neurons=3, max_epochs=3).fit(u, y, fs=500.0).save(d / "good.npz")
    with np.load(good, allow_pickle=False) as z:
        files = dict(z.items())
    meta = json.loads(str(files["metadata"]))
    newer = {**files, "metadata": np.array(json.dumps({**meta, "format_version": 99}))}
    np.savez(d / "newer.npz", **newer)
    np.savez(d / "tampered.npz", **{**files, "W": files["W"][:, :-1]})
    (d / "text.npz").write_text("not a model\n")
    return d


def snapshot(*roots: Path) -> dict[str, tuple[int, int, str]]:
    """Every file under ``roots``: (size, mtime in ns, SHA-256) by path."""
    import hashlib

    out = {}
    for root in roots:
        for p in root.rglob("*"):
            if p.is_file():
                st = p.stat()
                out[str(p)] = (st.st_size, st.st_mtime_ns,
                               hashlib.sha256(p.read_bytes()).hexdigest())
    return out


def check_cli(tmp_path, model_files, setup, argv, match):
    """Run ``sloshrom ARGV`` and check the bad-input contract.

    Exit code exactly 2, no exception but the clean exit, no traceback, exactly one
    ``error:`` line matching ``match``, and no file created, removed or modified (names, sizes,
    modification times and contents of every file under the test's directories).
    """
    if setup is not None:
        setup(tmp_path)
    before = snapshot(tmp_path, model_files)
    args = [a.format(tmp=tmp_path, models=model_files) for a in argv]
    res = runner.invoke(app, args)
    out = res.output
    assert res.exit_code == 2, out
    # a clean exit (typer.Exit -> SystemExit), not an exception escaping the command
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in out
    errors = [ln for ln in out.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1, out
    assert re.search(match, errors[0]), errors[0]
    after = snapshot(tmp_path, model_files)
    new = sorted(set(after) - set(before))
    assert not new, f"files left behind: {new}"
    gone = sorted(set(before) - set(after))
    assert not gone, f"files removed: {gone}"
    changed = sorted(k for k in before if before[k] != after[k])
    assert not changed, f"files modified: {changed}"


def model_parts(path):
    with np.load(path, allow_pickle=False) as z:
        files = dict(z.items())
    return json.loads(str(files.pop("metadata"))), files


def write_model_parts(path, meta, arrays, recompute=True):
    if recompute:
        meta["checksum"] = modelfile.checksum(meta, arrays)
    np.savez(path, metadata=np.array(json.dumps(meta)), **arrays)
    return path


class LinearDamper:
    """Stand-in sloshing model: a viscous damper df = -c v (a JaxModel, not a pytree)."""

    jax_traceable = True
    force_rule = "trapezoid"

    def __init__(self, c: float, dt: float) -> None:
        self.c, self.dt = c, dt

    def init_state(self):
        return jnp.zeros(0)

    def step(self, state, velocity, acceleration):
        return state, -self.c * velocity

    def simulate(self, velocity, acceleration):
        return -self.c * np.asarray(velocity)


class NumpyDamper(LinearDamper):
    """The same, declared not jax-traceable: the Python loop."""

    jax_traceable = False


@nb.njit
def _damper_kernel_step(state, params, velocity, acceleration):
    state[0] += 1.0  # counts steps: the state is advanced in place
    return -params[0] * velocity


class NumbaDamper:
    """Stand-in with the rig's kernel() contract (numba step function advancing state)."""

    def __init__(self, c: float, dt: float) -> None:
        self.c, self.dt = c, dt

    def init_state(self):
        return np.zeros(1)

    def step(self, state, velocity, acceleration):
        return state + 1.0, -self.c * velocity

    def kernel(self):
        return _damper_kernel_step, np.array([self.c]), self.init_state()


def smooth_io(n=2000, seed=1):
    """Smooth random velocity (m/s) and a delayed saturating force (N) of it."""
    rng = np.random.default_rng(seed)
    u = np.convolve(rng.standard_normal(n), np.ones(8) / 8, mode="same") * 0.3
    u[:10] = 0.0
    y = 40.0 * np.tanh(5 * np.concatenate([[0.0, 0.0], u[:-2]]))
    return u, y


def assert_bit_identical(a, b, what: str = "") -> None:
    """Equal to the last bit (float64 bit patterns): a property of one machine, never of two."""
    bits = [np.ascontiguousarray(x, dtype=np.float64).view(np.uint64) for x in (a, b)]
    np.testing.assert_array_equal(bits[0], bits[1], err_msg=what)


#: smallest tolerance against a stored reference: 8 roundings of a float64, relative
FLOOR = 8 * 2.0**-53


def relative_change(a, b) -> float:
    """``max|a - b| / max|b|`` over the entries where both are finite."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = max(float(np.nanmax(np.abs(b))), np.finfo(float).tiny)
    d = np.abs(a - b)
    d = d[np.isfinite(d)]
    return float(d.max()) / scale if d.size else 0.0


def perturbation_tolerance(fn, x, eps: float = 1e-13, draws: int = 3, seed: int = 0) -> float:
    """Largest relative change of ``fn(x)`` when ``x`` moves by a relative ``eps`` per sample.

    A tolerance for comparing ``fn(x)`` with a value stored on another CPU: ``eps`` = 1e-13 is
    above the relative differences that other instruction sets make in our inputs (8e-14).
    """
    rng = np.random.default_rng(seed)
    x = np.asarray(x, dtype=float)
    base = fn(x)
    moved = (fn(x * (1.0 + eps * rng.uniform(-1.0, 1.0, x.shape))) for _ in range(draws))
    return max(FLOOR, *(relative_change(m, base) for m in moved))


class Interrupt(Exception):
    """Raised by a progress callback to stop a reproduce run."""


#: every stage of `reproduce` at the smallest sizes its configuration allows (random tests: one
#: Welch segment), with a sweep of three networks
TINY_REPRODUCE = """
[data]
train_duration = 20.0
validation_duration = 12.0
design = "shaker"
[rom]
arch = "nfir"
compare = []
ensemble = 1
sweep_nfir_delays = [4, 6]
sweep_nfir_neurons = [2]
sweep_noe_delays = [2]
sweep_noe_neurons = [2]
sweep_workers = 1
[rom.nfir]
delays = 6
neurons = 3
max_epochs = 3
[map]
n_omega = 3
n_a = 3
[beam]
free_duration = 3.0
random_duration = 34.0
rms_g = [0.2]
"""


def reproduce_interrupted_then_resumed(out, cfg, argv, logs=None):
    """Run until the maps stage starts, then ``sloshrom reproduce ARGV``; the summary (and the
    command's output appended to the list ``logs``, if given)."""

    def stop_at_maps(stage, done, total, text):
        if stage == "maps":
            raise Interrupt

    from sloshrom.pipeline import run

    with pytest.raises(Interrupt):
        run(out, cfg, progress=stop_at_maps)
    assert (out / "models" / "nfir.npz").is_file()
    assert not (out / "report.html").exists()
    res = CliRunner().invoke(app, ["reproduce", *argv, "--out", str(out)])
    assert res.exit_code == 0, res.output
    if logs is not None:
        logs.append(res.output)
    return json.loads((out / "summary.json").read_text())


#: A "use" programme of `sloshrom design` (and the data stage) in seconds: five short segments
#: (two VFA pieces, two random levels, one decay).
TINY_DESIGN_TOML = """[data]
design = "use"
train_duration = 12.0
validation_duration = 12.0
extension_duration = 20.0
random_factors = [1.0]
random_duration = 10.0
decay_factors = [1.0]
decay_duration = 3.0

[beam]
free_duration = 3.0
random_duration = 40.0
rms_g = [0.1, 0.3]
"""


def _data_points(ax) -> np.ndarray:
    """The display coordinates (n, 2) of what an axes plots as points: its lines' vertices and
    its scatters' offsets (what matplotlib's ``loc="best"`` counts too)."""
    pts = [ln.get_transform().transform(ln.get_xydata()) for ln in ax.get_lines()
           if ln.get_visible() and len(ln.get_xydata())]
    for c in ax.collections:
        off = c.get_offsets()
        if c.get_visible() and len(off) and c.get_offset_transform() is not None:
            pts.append(c.get_offset_transform().transform(off))
    pts = [p for p in pts if p.ndim == 2 and p.shape[1] == 2]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def legend_placement(ax, renderer) -> dict | None:
    """Where an axes' legend lies over its data: ``over`` (the data points under the legend),
    ``best`` (the fewest under a legend of its size at any of the nine places ``loc`` names,
    inside the axes) and ``inside`` (whether it overlaps the axes at all); None without a
    legend."""
    leg = ax.get_legend()
    if leg is None or not leg.get_visible():
        return None
    box, frame = leg.get_window_extent(renderer), ax.get_window_extent(renderer)
    pts = _data_points(ax)
    pts = pts[np.all(np.isfinite(pts), axis=1)]

    def under(x0: float, y0: float) -> int:
        x, y = pts[:, 0], pts[:, 1]
        return int(np.count_nonzero((x >= x0) & (x <= x0 + box.width)
                                    & (y >= y0) & (y <= y0 + box.height)))

    inside = box.overlaps(frame)
    pad = 0.5 * leg.prop.get_size_in_points() * renderer.points_to_pixels(1.0)
    xs = np.linspace(frame.x0 + pad, frame.x1 - pad - box.width, 3)
    ys = np.linspace(frame.y0 + pad, frame.y1 - pad - box.height, 3)
    return {"over": under(box.x0, box.y0) if inside else 0, "inside": bool(inside),
            "best": min(under(x, y) for x in xs for y in ys), "points": int(len(pts))}


def figure_axes(fig) -> dict:
    """What a matplotlib figure shows, for tests of its labels: its title (the suptitle, or its
    first axes' title) and, for each axes that holds data (not a colour bar), its labels, its
    position in its grid, whether its x axis is shared, and where its legend lies over its data
    (:func:`legend_placement`; the figure drawn, as it is saved)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    # the figures are made without pyplot (no canvas with a renderer): Agg's, as savefig's
    renderer = (fig.canvas if isinstance(fig.canvas, FigureCanvasAgg)
                else FigureCanvasAgg(fig)).get_renderer()
    fig.draw(renderer)
    axes = []
    for ax in fig.get_axes():
        if ax.get_label() == "<colorbar>" or not ax.has_data():
            continue
        spec = ax.get_subplotspec()
        axes.append({"title": ax.get_title(), "xlabel": ax.get_xlabel(),
                     "ylabel": ax.get_ylabel(),
                     "last_row": spec is None or spec.is_last_row(),
                     "first_col": spec is None or spec.is_first_col(),
                     "sharex": len(ax.get_shared_x_axes().get_siblings(ax)) > 1,
                     "legend_texts": [t.get_text() for t in ax.get_legend().get_texts()]
                     if ax.get_legend() else [],
                     "legend": legend_placement(ax, renderer)})
    title = fig.get_suptitle() or next((a["title"] for a in axes if a["title"]), "")
    return {"title": title, "axes": axes}
