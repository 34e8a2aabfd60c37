"""Export a fitted sloshrom ROM (NFIR or NOE) to ONNX, for Simulink and other simulators.

Two graphs, both with the min-max scalers inside (inputs and outputs in physical units):

``form="step"`` (default; the one a fixed-step simulator calls once per sample):
    inputs  ``velocity``  (batch, 1), m/s, tank vertical velocity at the current sample k;
            ``u_state``   (batch, max_delay), m/s, past velocities, most recent first
            (``u_state[:, i] = u_{k-1-i}``); all zeros = at rest;
            NOE only: ``y_state`` (batch, out_delays), N, past ROM outputs, most recent first.
    outputs ``dynamic_force`` (batch, 1), N, the ROM output at sample k (it depends on the past
            inputs only: ``y_k = f(u_{k-d_1}, ..., u_{k-d_n}[, y_{k-1}, ...])``);
            ``u_state_out`` = ``[u_k, u_state[:, :-1]]`` (and ``y_state_out`` =
            ``[y_k, y_state[:, :-1]]``): feed them back as the next step's state.

``form="sequence"``: an ONNX ``Scan`` of the step over a whole record from rest:
    input ``velocity`` (n,) m/s -> output ``dynamic_force`` (n,) N; equals ``model.predict``.

Metadata (``metadata_props``, all strings): format/format version, model class, sample rate,
delays, neurons, hidden layer kind, units and names of input/output, sign convention, state
layout, training envelope, sloshrom version.

The arithmetic follows :mod:`sloshrom.rom.tdnn.network` exactly: ``x = scale(u)``, ``n = x W^T + b``
(``"matlab"``) or ``n^2 = b^2 ||x - C||^2`` (``"distance"``), ``a = softmax(-n^2)``,
``y = unscale(a . c + c0)``. Double precision by default (parity with the JAX model to ~1e-15);
``dtype="float32"`` for tools that only take single precision (MATLAB ``importNetworkFromONNX``).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sloshrom import __version__
from sloshrom.fileio import atomic_write
from sloshrom.models import input_of
from sloshrom.rom.ensemble import is_ensemble
from sloshrom.rom.errors import ROMError
from sloshrom.rom.network import network_of
from sloshrom.rom.registry import CLASSES

if TYPE_CHECKING:
    from sloshrom.rom.tdnn.estimators import NFIR, NOE

    ROM = NFIR | NOE

__all__ = ["ONNX_FORMAT_VERSION", "SIGN_CONVENTION", "check_exportable", "export_onnx",
           "onnx_model", "run_onnx"]

#: version of the ONNX graph layout and metadata (not the ``.npz`` model-file format version)
ONNX_FORMAT_VERSION = 1
OPSET = 17
SIGN_CONVENTION = (
    "input: tank vertical velocity w_dot (m/s), w up positive; output: dynamic sloshing force "
    "df = f_S + m_l * w_ddot (N), the force the liquid exerts on the tank beyond that of the "
    "frozen liquid, positive up"
)


def _delays(model: ROM) -> np.ndarray:
    """Input delays (samples) of the model's architecture."""
    return np.asarray(model.spec.delays, dtype=np.int64)


class _Graph:
    """Tiny helper that names nodes/initializers uniquely while a graph is built."""

    def __init__(self, prefix: str, dtype: Any) -> None:
        self.prefix, self.dtype = prefix, np.dtype(dtype)
        self.nodes: list[Any] = []
        self.inits: list[Any] = []
        self._n = 0

    def name(self, base: str) -> str:
        self._n += 1
        return f"{self.prefix}{base}_{self._n}"

    def const(self, base: str, value: Any, dtype: Any = None) -> str:
        from onnx import numpy_helper

        arr = np.asarray(value, dtype=dtype or self.dtype)
        n = self.name(base)
        self.inits.append(numpy_helper.from_array(arr, n))
        return n

    def op(self, op_type: str, inputs: list[str], base: str | None = None, out: str | None = None,
           **attrs: Any) -> str:
        from onnx import helper

        o = out or self.name(base or op_type.lower())
        self.nodes.append(helper.make_node(op_type, inputs, [o], **attrs))
        return o


def _scale(g: _Graph, x: str, lo: float, hi: float, base: str) -> str:
    """``2 (x - lo) / (hi - lo) - 1`` (same operation order as MinMaxScaler)."""
    t = g.op("Sub", [x, g.const(f"{base}_min", lo)])
    t = g.op("Mul", [t, g.const("two", 2.0)])
    t = g.op("Div", [t, g.const(f"{base}_range", hi - lo)])
    return g.op("Sub", [t, g.const("one", 1.0)])


def _rbf(g: _Graph, x_s: str, params: dict[str, np.ndarray], hidden: str) -> str:
    """Scaled network output (batch, 1) for scaled regressors ``x_s`` (batch, D)."""
    W = np.asarray(params["W"], dtype=np.float64)
    b = np.asarray(params["b"], dtype=np.float64)
    c = np.asarray(params["c"], dtype=np.float64)
    c0 = float(np.asarray(params["c0"]))
    if hidden == "matlab":
        n = g.op("Add", [g.op("MatMul", [x_s, g.const("WT", W.T)]), g.const("b", b)])
        n2 = g.op("Mul", [n, n])
    elif hidden == "distance":
        xx = g.op("ReduceSum", [g.op("Mul", [x_s, x_s]), g.const("ax", [-1], np.int64)],
                  keepdims=1)
        xw = g.op("MatMul", [x_s, g.const("WT", W.T)])
        d2 = g.op("Sub", [xx, g.op("Mul", [g.const("two", 2.0), xw])])
        d2 = g.op("Add", [d2, g.const("WW", np.sum(W**2, axis=-1))])
        d2 = g.op("Max", [d2, g.const("zero", 0.0)])
        n2 = g.op("Mul", [g.const("b2", b**2), d2])
    else:
        raise ROMError(f"unknown hidden layer kind {hidden!r}")
    a = g.op("Softmax", [g.op("Neg", [n2])], axis=-1)
    y = g.op("MatMul", [a, g.const("c", c[:, None])])
    return g.op("Add", [y, g.const("c0", c0)])


def _step_nodes(g: _Graph, model: ROM, velocity: str, u_state: str, y_state: str | None,
                out_y: str, out_u_state: str, out_y_state: str | None) -> None:
    """Nodes of one step (see module docstring) writing ``out_*``."""
    s = model.scaler_
    d = _delays(model).astype(np.int64)
    parts = [g.op("Gather", [u_state, g.const("delay_idx", d - 1, np.int64)], axis=1)]
    if y_state is not None:
        parts.append(y_state)
    x = parts[0] if len(parts) == 1 else g.op("Concat", parts, axis=1)
    if y_state is None:
        x_s = _scale(g, x, s.in_min, s.in_max, "in")
    else:  # input and output parts of the regressor have their own scalers
        xu_s = _scale(g, parts[0], s.in_min, s.in_max, "in")
        xy_s = _scale(g, y_state, s.out_min, s.out_max, "out")
        x_s = g.op("Concat", [xu_s, xy_s], axis=1)
    y_s = _rbf(g, x_s, model.params_, model.hidden)
    # inverse output scaling, same order as MinMaxScaler.y_inverse
    t = g.op("Add", [y_s, g.const("one", 1.0)])
    t = g.op("Mul", [t, g.const("half", 0.5)])
    t = g.op("Mul", [t, g.const("out_range", s.out_max - s.out_min)])
    g.op("Add", [t, g.const("out_min", s.out_min)], out=out_y)
    dmax = int(d.max())

    def shift(state: str, new: str, length: int, out: str) -> None:
        if length == 1:
            g.op("Identity", [new], out=out)
            return
        kept = g.op("Slice", [state, g.const("s0", [0], np.int64),
                              g.const("s1", [length - 1], np.int64),
                              g.const("sax", [1], np.int64)])
        g.op("Concat", [new, kept], axis=1, out=out)

    shift(u_state, velocity, dmax, out_u_state)
    if y_state is not None and out_y_state is not None:
        shift(y_state, out_y, model.spec.out_delays, out_y_state)


def _metadata(model: ROM, form: str, dtype: np.dtype) -> dict[str, str]:
    noe = model.spec.out_delays > 0  # the output feedback makes the graph recurrent
    state = ("u_state (batch, max_delay) m/s, past velocities most recent first, zeros = rest"
             + ("; y_state (batch, out_delays) N, past outputs most recent first, zeros = rest"
                if noe else ""))
    meta = {
        "format": "sloshrom-onnx",
        "format_version": str(ONNX_FORMAT_VERSION),
        "form": form,
        "dtype": dtype.name,
        "model_class": type(model).__name__,
        "sample_rate_hz": repr(float(model.fs_)),
        "dt_s": repr(1.0 / float(model.fs_)),
        "delays": json.dumps([int(x) for x in _delays(model)]),
        "max_delay": str(int(_delays(model).max())),
        "out_delays": str(model.spec.out_delays),
        "neurons": str(int(model.neurons)),
        "hidden": str(model.hidden),
        "input_name": str(model.names[0]),
        "input_unit": str(model.units[0]),
        "output_name": str(model.names[1]),
        "output_unit": str(model.units[1]),
        "sign_convention": SIGN_CONVENTION,
        "state": state if form == "step" else "none (sequence from rest)",
        "scaler": json.dumps(model.scaler_.to_dict()),
        "envelope": json.dumps(model.envelope_ or {}),
        "sloshrom_version": __version__,
    }
    return meta


def check_exportable(model: Any) -> None:
    """ROMError unless ``model`` is one NFIR or NOE network (what an ONNX graph holds); a
    state-space network (NSS) is refused with the reason, and a class with a note on ONNX
    (:attr:`~sloshrom.rom.registry.ModelClass.export_notes`) with its note."""
    if is_ensemble(model):
        raise ROMError(
            f"an ensemble ({len(model.members_)} {model.member_class} members) cannot be "
            "exported to ONNX: a graph holds one network; export a single model "
            "(`sloshrom train` without --ensemble) or one member (Ensemble.members_[k].save)"
        )
    net = network_of(model)
    if net is not None and "onnx" not in net.model_class.exports:
        note = net.model_class.export_notes.get("onnx")
        if note is not None:  # the class says why
            raise ROMError(f"the {net.describe()} cannot be exported to ONNX: {note}")
        held = " or ".join(mc.class_name for mc in CLASSES.values() if "onnx" in mc.exports)
        raise ROMError(f"an {net.describe()} cannot be exported to ONNX: a graph holds one "
                       f"{held} network; a state-space ROM's step graph would need its "
                       "state as input and output, which is not implemented. Export it as "
                       "an FMU (`sloshrom export fmu`) or run it through sloshrom (Python "
                       "API: step/simulate; command line: predict, map, beam)")
    if net is None:  # a family, a ball
        raise ROMError(f"a {type(model).__name__} cannot be exported to ONNX: a graph holds "
                       "one NFIR or NOE network (export a fill family's members one by one)")
    if input_of(model) == "acceleration":
        # the step graph's contract is the velocity's (evaluate, then push the current input)
        raise ROMError("a network on the tank acceleration cannot be exported to ONNX: the "
                       "graphs take the tank velocity")


def onnx_model(model: ROM, form: str = "step", dtype: str = "float64") -> Any:
    """Build the ONNX ``ModelProto`` of a fitted NFIR/NOE (see module docstring).

    Parameters
    ----------
    model : sloshrom.rom.NFIR or sloshrom.rom.NOE
        Fitted (``params_``, ``scaler_``, ``fs_``).
    form : {"step", "sequence"}
        One step with explicit delay-line state, or a whole record from rest (``Scan``).
    dtype : {"float64", "float32"}
        Precision of every tensor of the graph.

    Returns
    -------
    onnx.ModelProto
        Checked with ``onnx.checker``.

    Raises
    ------
    ROMError
        An unfitted model, an ensemble (one network per graph), an unknown ``form`` or
        ``dtype``.
    """
    import onnx
    from onnx import TensorProto, helper

    check_exportable(model)
    if network_of(model) is None:
        raise ROMError("the model is not fitted: nothing to export")
    if form not in ("step", "sequence"):
        raise ROMError(f"form must be 'step' or 'sequence', got {form!r}")
    if dtype not in ("float64", "float32"):
        raise ROMError(f"dtype must be 'float64' or 'float32', got {dtype!r}")
    dt = np.dtype(dtype)
    elem = TensorProto.DOUBLE if dt == np.float64 else TensorProto.FLOAT
    noe = model.spec.out_delays > 0  # the output feedback makes the graph recurrent
    dmax, m = model.spec.max_delay, model.spec.out_delays

    if form == "step":
        g = _Graph("", dt)
        _step_nodes(g, model, "velocity", "u_state", "y_state" if noe else None,
                    "dynamic_force", "u_state_out", "y_state_out" if noe else None)
        inputs = [helper.make_tensor_value_info("velocity", elem, ["batch", 1]),
                  helper.make_tensor_value_info("u_state", elem, ["batch", dmax])]
        outputs = [helper.make_tensor_value_info("dynamic_force", elem, ["batch", 1]),
                   helper.make_tensor_value_info("u_state_out", elem, ["batch", dmax])]
        if noe:
            inputs.append(helper.make_tensor_value_info("y_state", elem, ["batch", m]))
            outputs.append(helper.make_tensor_value_info("y_state_out", elem, ["batch", m]))
        graph = helper.make_graph(g.nodes, f"sloshrom_{type(model).__name__}_step", inputs,
                                  outputs, g.inits)
    else:
        # Scan body: states (1, dmax)[, (1, m)], scan input u_k (1,) -> states, y_k (1,)
        b = _Graph("body_", dt)
        uk = b.op("Reshape", ["u_k", b.const("shape11", [1, 1], np.int64)])
        _step_nodes(b, model, uk, "us_in", "ys_in" if noe else None, "y_k11", "us_out",
                    "ys_out" if noe else None)
        b.op("Reshape", ["y_k11", b.const("shape1", [1], np.int64)], out="y_k")
        body_in = [helper.make_tensor_value_info("us_in", elem, [1, dmax])]
        body_out = [helper.make_tensor_value_info("us_out", elem, [1, dmax])]
        if noe:
            body_in.append(helper.make_tensor_value_info("ys_in", elem, [1, m]))
            body_out.append(helper.make_tensor_value_info("ys_out", elem, [1, m]))
        body_in.append(helper.make_tensor_value_info("u_k", elem, [1]))
        body_out.append(helper.make_tensor_value_info("y_k", elem, [1]))
        body = helper.make_graph(b.nodes, "step", body_in, body_out, b.inits)
        g = _Graph("", dt)
        u2 = g.op("Reshape", ["velocity", g.const("shape_n1", [-1, 1], np.int64)])
        states = [g.const("u_rest", np.zeros((1, dmax)))]
        finals = ["u_state_final"]
        if noe:
            states.append(g.const("y_rest", np.zeros((1, m))))
            finals.append("y_state_final")
        from onnx import helper as h

        g.nodes.append(h.make_node("Scan", [*states, u2], [*finals, "y_n1"],
                                   num_scan_inputs=1, body=body))
        g.op("Reshape", ["y_n1", g.const("shape_n", [-1], np.int64)], out="dynamic_force")
        graph = helper.make_graph(
            g.nodes, f"sloshrom_{type(model).__name__}_sequence",
            [helper.make_tensor_value_info("velocity", elem, ["n"])],
            [helper.make_tensor_value_info("dynamic_force", elem, ["n"])], g.inits)
    proto = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)],
                              producer_name="sloshrom", ir_version=8)
    meta = _metadata(model, form, dt)
    helper.set_model_props(proto, meta)
    proto.doc_string = (f"sloshrom {meta['model_class']} ROM, {form} form: "
                        f"{meta['input_name']} [{meta['input_unit']}] -> "
                        f"{meta['output_name']} [{meta['output_unit']}] at "
                        f"{float(model.fs_):g} Hz. {SIGN_CONVENTION}.")
    onnx.checker.check_model(proto, full_check=True)
    return proto


def export_onnx(
    model: ROM,
    path: str | Path,
    form: str = "step",
    dtype: str = "float64",
    verify: Callable[[Path], None] | None = None,
) -> Path:
    """Write the ONNX graph of a fitted ROM atomically (temporary file, then rename).

    The graph is built and checked before anything is written; it is then written completely
    to a temporary file beside ``path``, optionally verified there, and only then renamed onto
    ``path``. A failure at any step (including in ``verify``) leaves a previous ``path``, if any,
    untouched and no temporary file behind.

    Parameters
    ----------
    model : sloshrom.rom.NFIR or sloshrom.rom.NOE
    path : str or Path
        Output ``.onnx`` file.
    form, dtype
        See :func:`onnx_model`.
    verify : callable, optional
        ``verify(tmp_path)`` is called with the complete temporary file (a ``.onnx`` name);
        raising rejects the export (e.g. an onnxruntime parity check that fails).

    Returns
    -------
    Path
    """
    import onnx

    proto = onnx_model(model, form=form, dtype=dtype)
    p = Path(path)

    def write(tmp: str) -> None:
        onnx.save_model(proto, tmp)
        if verify is not None:
            verify(Path(tmp))

    return atomic_write(p, write, suffix=".onnx")


def run_onnx(path: str | Path, u: Any) -> np.ndarray:
    """Free-run output of an exported graph (either form) for input ``u`` with onnxruntime.

    Parameters
    ----------
    path : str or Path
        An ``.onnx`` file written by :func:`export_onnx`.
    u : array_like, shape (n,)
        Input record from rest (physical units, e.g. m/s), at the model's sample rate.

    Returns
    -------
    ndarray, shape (n,)
        Output (physical units, e.g. N), float64 (computed in the graph's precision).
    """
    import onnxruntime as ort

    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    meta = sess.get_modelmeta().custom_metadata_map
    dt = np.dtype(meta.get("dtype", "float64"))
    u = np.asarray(u, dtype=dt)
    if meta.get("form") == "sequence":
        return sess.run(None, {"velocity": u})[0].astype(float)
    state = {i.name: np.zeros((1, i.shape[1]), dt) for i in sess.get_inputs()
             if i.name != "velocity"}
    y = np.empty(u.size)
    for k in range(u.size):
        res = sess.run(None, {"velocity": u[k : k + 1].reshape(1, 1), **state})
        y[k] = res[0][0, 0]
        state = {name: r for name, r in zip(state, res[1:], strict=True)}
    return y
