"""Speed of one ROM step in the exported FMU's native code against our JAX step, in one run.

For four ROMs -- the paper-size NFIR (70 delays, 35 neurons), the default NOE (delays 1, 2;
two output delays; 10 neurons), an NSS of the default size (8 states, 64 neurons) and an
ensemble of two such NSS (the default ROM of ``sloshrom reproduce``) -- each trained for a
couple of epochs on a 12 s virtual-rig record (the weights do not change the arithmetic),
exported with :func:`sloshrom.rom.fmu.export_fmu` and stepped on the same smooth input inside
the model's training envelope, one sample per step:

- ``native``: a C driver (written and compiled here, ``cc -O2 driver.c -ldl``) ``dlopen``-s the
  FMU's binary and runs ``fmi2SetReal(velocity); fmi2GetReal(dynamic_force); fmi2DoStep`` per
  sample, timed with ``clock_gettime(CLOCK_MONOTONIC)`` (instantiation excluded), median of the
  repeats. Its checksums (the sums of the forces and of their magnitudes, added in order) must
  equal those of the same FMU run through :meth:`sloshrom.rom.fmu.FMUModel.predict` to 1e-12
  relative: the timed loop is the real computation;
- ``JAX call``: ``jax.jit(model.step)`` called from Python once per sample with the state
  carried and the force read back as a float (what a user's own loop around our step gets);
- ``JAX scan``: the same step in a compiled ``lax.scan`` over the whole input, the model a jit
  argument as in the coupled beam (the amortised cost of our step in a compiled loop);
- ``simulate``: ``model.simulate(velocity)`` per sample (an NFIR's free run is not a
  recurrence: it evaluates all samples in parallel chunks);
- ``FMPy``: :meth:`sloshrom.rom.fmu.FMUModel.step` per sample (the FMU through FMPy's ctypes:
  what the coupled beam's Python loop pays with an FMU model).

All in float64. Compilation is excluded (warm-up calls first); each figure is the median of
repeated timed loops. ``FLOP`` is the multiply-adds of the step's products counted from the
architecture (2 per weight of each matrix-vector product; tanh, exp and the softmax's sums are
not counted). The ratios ``call/native`` and ``scan/native`` are what native code gains.
The maximum difference between the FMU's force and ``model.simulate``'s (relative to the
largest force) is printed for each model.

Run: ``.venv/bin/python benchmarks/fmu_speed.py`` (about 30 s on a 2-core VM; ``--quick``, a
smoke run, about 20 s; ``--steps N``: samples per native, scan and simulate loop, N/20 for the
Python loops).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import tempfile
import time
import warnings
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

#: relative tolerance of the native checksum against FMUModel.predict's
CHECKSUM_RTOL = 1e-12

DRIVER = r"""
/* Times N steps of a sloshrom FMU's native code: setReal(velocity); getReal(force); doStep. */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "fmi2FunctionTypes.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list ap;
    (void)env;
    fprintf(stderr, "FMU %s [status %d, %s]: ", name ? name : "", (int)status,
            category ? category : "");
    va_start(ap, message);
    vfprintf(stderr, message, ap);
    va_end(ap);
    fputc('\n', stderr);
}

#define LOAD(var, name)                                                 \
    var = (name##TYPE *)dlsym(lib, #name);                              \
    if (var == NULL) {                                                  \
        fprintf(stderr, "no %s in the binary: %s\n", #name, dlerror()); \
        return 2;                                                       \
    }

int main(int argc, char **argv) {
    fmi2InstantiateTYPE *instantiate;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter_init;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2TerminateTYPE *terminate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    const fmi2ValueReference vr_in = 0, vr_force = 2, vr_dt = 10;
    void *lib;
    double *u;
    long n, k;
    int rep, repeats;
    FILE *f;

    if (argc != 6) {
        fprintf(stderr, "usage: driver binary.so guid resource_uri input.f64 repeats\n");
        return 2;
    }
    repeats = atoi(argv[5]);
    f = fopen(argv[4], "rb");
    if (f == NULL) { perror(argv[4]); return 2; }
    fseek(f, 0, SEEK_END);
    n = ftell(f) / (long)sizeof(double);
    rewind(f);
    u = malloc((size_t)n * sizeof(double));
    if (u == NULL || fread(u, sizeof(double), (size_t)n, f) != (size_t)n) {
        fprintf(stderr, "cannot read %s\n", argv[4]);
        return 2;
    }
    fclose(f);
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) { fprintf(stderr, "dlopen: %s\n", dlerror()); return 2; }
    LOAD(instantiate, fmi2Instantiate)
    LOAD(setup, fmi2SetupExperiment)
    LOAD(enter_init, fmi2EnterInitializationMode)
    LOAD(exit_init, fmi2ExitInitializationMode)
    LOAD(set_real, fmi2SetReal)
    LOAD(get_real, fmi2GetReal)
    LOAD(do_step, fmi2DoStep)
    LOAD(terminate, fmi2Terminate)
    LOAD(free_instance, fmi2FreeInstance)

    for (rep = 0; rep < repeats; rep++) {
        struct timespec t0, t1;
        double dt, force, sum = 0.0, abs_sum = 0.0;
        int worst = fmi2OK;
        fmi2Component c = instantiate("bench", fmi2CoSimulation, argv[2], argv[3], &cb,
                                      fmi2False, fmi2False);
        if (c == NULL) { fprintf(stderr, "fmi2Instantiate failed\n"); return 1; }
        if (setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK
            || enter_init(c) != fmi2OK || exit_init(c) != fmi2OK
            || get_real(c, &vr_dt, 1, &dt) != fmi2OK) {
            fprintf(stderr, "initialisation failed\n");
            return 1;
        }
        clock_gettime(CLOCK_MONOTONIC, &t0);
        for (k = 0; k < n; k++) {
            int s1 = set_real(c, &vr_in, 1, &u[k]);
            int s2 = get_real(c, &vr_force, 1, &force);
            int s3 = do_step(c, (double)k * dt, dt, fmi2True);
            /* statuses are checked as a master would; the sums keep the loop's work */
            worst |= s1 | s2 | s3;
            sum += force;
            abs_sum += fabs(force);
        }
        clock_gettime(CLOCK_MONOTONIC, &t1);
        if (worst > fmi2Warning) { fprintf(stderr, "an FMI call failed\n"); return 1; }
        printf("%.6f %.17g %.17g\n",
               ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec))
                   / (double)n, sum, abs_sum);
        terminate(c);
        free_instance(c);
    }
    free(u);
    dlclose(lib);
    return 0;
}
"""


# -- models --------------------------------------------------------------------------------------
def record(duration: float = 12.0, seed: int = 1) -> tuple[np.ndarray, np.ndarray, float]:
    """A virtual-rig VFA training record: tank velocity (m/s), dynamic force (N), fs (Hz)."""
    from sloshrom.io import record_from_measurement
    from sloshrom.rig.virtual import VirtualRig
    from sloshrom.signals import vfa

    rig = VirtualRig(seed=seed)
    path = vfa(1.0 / rig.dt, "train", duration=duration, seed=seed)
    rec = record_from_measurement(rig.measure(path.acceleration))
    return rec["velocity"], rec["dynamic_force"], rec.fs


def train_models() -> list[tuple[str, object]]:
    """The four ROMs, each after a couple of epochs (seeded)."""
    from sloshrom.rom import NFIR, NOE, NSS
    from sloshrom.rom.ensemble import Ensemble

    u, y, fs = record()
    nss = dict(max_epochs=1, steps_per_epoch=2, seed=0)
    return [
        ("NFIR(70, 35)", NFIR(70, 35, max_epochs=2, seed=0).fit(u, y, fs=fs)),
        ("NOE(2, 10, 2)", NOE(max_epochs=2, seed=0).fit(u, y, fs=fs)),
        ("NSS(8, 64)", NSS(**nss).fit(u, y, fs=fs)),
        # the members one after the other: the same networks, no Dask cluster to start
        ("Ensemble 2 x NSS", Ensemble(NSS(**nss), n_members=2).fit(
            u, y, fs=fs, scheduler="sequential")),
    ]


def flops_per_step(model: object) -> int:
    """Multiply-adds (2 FLOP each) of the products of one step, summed over the members."""
    from sloshrom.rom.fmu import check_fmu_exportable
    from sloshrom.rom.nss.network import StateSpaceSpec

    total = 0
    for net in check_fmu_exportable(model):
        keys = (("A", "W1", "W2", "C", "V1", "V2") if isinstance(net.spec, StateSpaceSpec)
                else ("W", "c"))
        total += sum(2 * np.asarray(net.params[k]).size for k in keys)
    return total


def smooth_input(model: object, n: int) -> np.ndarray:
    """A smooth velocity (m/s) from rest, inside 80 % of the model's training range."""
    from sloshrom.models import envelope_of

    env = envelope_of(model)
    reach = min(-env.input_min, env.input_max)  # from rest (0) to the nearer bound
    if not reach > 0:
        raise RuntimeError("the training range does not contain rest")
    t = np.arange(n) * model.dt
    shape = 0.6 * np.sin(2 * np.pi * 3.1 * t) + 0.4 * np.sin(2 * np.pi * 5.3 * t)
    return 0.8 * reach * shape


# -- timings -------------------------------------------------------------------------------------
def median_time(fn, repeat: int) -> float:
    """Median wall time of ``fn()`` over ``repeat`` calls, s."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def build_driver(sources: Path, work: Path) -> Path:
    """The C driver compiled against the FMU's FMI headers."""
    src = work / "driver.c"
    src.write_text(DRIVER, encoding="utf-8")
    exe = work / "driver"
    cc = os.environ.get("CC", "cc")
    subprocess.run([cc, "-O2", "-I", str(sources), str(src), "-ldl", "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    return exe


def native_times(fmu: Path, u: np.ndarray, work: Path, repeat: int
                 ) -> tuple[float, tuple[float, float]]:
    """Median ns per native step and the checksums (sum of forces, of |forces|), one run of
    the driver with ``repeat`` fresh instances."""
    from sloshrom.rom.fmu import fmu_platform

    root = work / fmu.stem
    with zipfile.ZipFile(fmu) as zf:
        zf.extractall(root)
    md = ET.parse(root / "modelDescription.xml").getroot()
    guid = md.get("guid")
    ident = md.find("CoSimulation").get("modelIdentifier")
    suffix = {"Darwin": ".dylib", "Windows": ".dll"}.get(platform.system(), ".so")
    binary = root / "binaries" / fmu_platform() / (ident + suffix)
    exe = build_driver(root / "sources", root)
    inp = root / "input.f64"
    u.astype("<f8").tofile(inp)
    resources = (root / "resources").as_uri()
    run = subprocess.run([str(exe), str(binary), guid, resources, str(inp), str(repeat)],
                         capture_output=True, text=True, check=False)
    if run.returncode != 0:
        raise RuntimeError(f"the native driver failed on {fmu.name}: {run.stderr.strip()}")
    rows = [[float(x) for x in line.split()] for line in run.stdout.split("\n") if line]
    sums = {(r[1], r[2]) for r in rows}
    if len(sums) != 1:
        raise RuntimeError(f"{fmu.name}: the native repeats disagree: {sums}")
    return statistics.median(r[0] for r in rows), sums.pop()


def jax_call_time(model: object, u: np.ndarray, repeat: int) -> float:
    """Median s per sample of ``jax.jit(model.step)`` called from a Python loop."""
    with jax.enable_x64(True):
        step = jax.jit(model.step)
        state = model.init_state()
        for k in range(3):  # compile (the first state may be a NumPy array) and warm up
            state, f = step(state, u[k])
            float(f)

        def loop() -> None:
            s = model.init_state()
            for x in u:
                s, f = step(s, x)
                float(f)

        return median_time(loop, repeat) / u.size


@jax.jit
def _scan(model: object, state: object, u: jnp.ndarray) -> jnp.ndarray:
    def body(s, x):
        return model.step(s, x)

    return jax.lax.scan(body, state, u)[1]


def jax_scan_time(model: object, u: np.ndarray, repeat: int) -> tuple[float, np.ndarray]:
    """Median s per sample of the step in a compiled ``lax.scan``, and its forces."""
    with jax.enable_x64(True):
        uj = jnp.asarray(u)
        state = model.init_state()
        out = np.asarray(_scan(model, state, uj))  # compile
        t = median_time(lambda: _scan(model, state, uj).block_until_ready(), repeat)
    return t / u.size, out


def simulate_time(model: object, u: np.ndarray, repeat: int) -> tuple[float, np.ndarray]:
    """Median s per sample of ``model.simulate(u)`` (compiled first), and its forces."""
    y = model.simulate(u)
    return median_time(lambda: model.simulate(u), repeat) / u.size, y


def fmpy_time(fm: object, u: np.ndarray, repeat: int) -> float:
    """Median s per sample of :meth:`FMUModel.step` from a Python loop."""

    def loop() -> None:
        s = fm.init_state()
        for x in u:
            s, _ = fm.step(s, x)

    return median_time(loop, repeat) / u.size


def in_order_sums(y: np.ndarray) -> tuple[float, float]:
    """Sums of ``y`` and ``|y|`` added in order (as the driver adds them)."""
    return float(np.cumsum(y)[-1]), float(np.cumsum(np.abs(y))[-1])


def compiler() -> str:
    cc = os.environ.get("CC", "cc")
    try:
        out = subprocess.run([cc, "--version"], capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        return f"{cc}: not found"
    return out.stdout.splitlines()[0]


def cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=None,
                        help="samples per native, scan and simulate loop (default 100000, "
                             "--quick 20000); the Python loops take 1/20 of them")
    parser.add_argument("--quick", action="store_true", help="a short smoke run")
    args = parser.parse_args()
    n = args.steps or (20_000 if args.quick else 100_000)
    n_py = max(n // 20, 100)
    repeat = 3 if args.quick else 5

    from sloshrom.models import EnvelopeWarning
    from sloshrom.rom.fmu import export_fmu, load_fmu

    print(f"{cpu()}, {os.cpu_count()} cores; {compiler()}; jax {jax.__version__}; "
          f"{n} samples per native/scan/simulate loop, {n_py} per Python loop; median of "
          f"{repeat}")
    t0 = time.perf_counter()
    models = train_models()
    print(f"trained the four models in {time.perf_counter() - t0:.1f} s")
    rows = []
    with tempfile.TemporaryDirectory(prefix="sloshrom-fmu-bench-") as tmp:
        work = Path(tmp)
        for name, model in models:
            u = smooth_input(model, n)
            fmu = export_fmu(model, work / f"{name.split('(')[0].split()[0].lower()}.fmu")
            native_ns, sums = native_times(fmu, u, work, repeat)
            fm = load_fmu(fmu)
            with warnings.catch_warnings():
                # the input is inside the envelope: a warning would mean a wrong input
                warnings.simplefilter("error", EnvelopeWarning)
                y_fmu = fm.predict(u)
            ref = in_order_sums(y_fmu)
            for a, b in zip(sums, ref, strict=True):
                if not abs(a - b) <= CHECKSUM_RTOL * abs(b):
                    raise RuntimeError(f"{name}: native checksum {a!r} != FMUModel.predict's "
                                       f"{b!r}")
            call = jax_call_time(model, u[:n_py], repeat)
            scan, y_scan = jax_scan_time(model, u, repeat)
            sim, y_sim = simulate_time(model, u, repeat)
            py = fmpy_time(fm, u[:n_py], repeat)
            fm.close()
            scale = float(np.max(np.abs(y_sim)))
            diff = max(float(np.max(np.abs(y_fmu - y_sim))),
                       float(np.max(np.abs(y_scan - y_sim)))) / scale
            rows.append((name, flops_per_step(model), native_ns, 1e6 * call, 1e9 * scan,
                         1e9 * sim, 1e6 * py, diff, sums[0]))
            print(f"{name}: done ({time.perf_counter() - t0:.0f} s)", flush=True)

    head = (f"{'model':<18}{'FLOP':>7}{'native':>10}{'JAX call':>10}{'JAX scan':>10}"
            f"{'simulate':>10}{'FMPy':>9}{'call/nat':>10}{'scan/nat':>10}")
    units = (f"{'':<18}{'/step':>7}{'ns':>10}{'us':>10}{'ns':>10}{'ns':>10}{'us':>9}"
             f"{'':>10}{'':>10}")
    print()
    print(head)
    print(units)
    for name, fl, nat, call, scan, sim, py, *_ in rows:
        print(f"{name:<18}{fl:>7}{nat:>10.0f}{call:>10.1f}{scan:>10.0f}{sim:>10.0f}"
              f"{py:>9.1f}{1e3 * call / nat:>10.0f}{scan / nat:>10.1f}")
    print("native: C driver -> FMU binary; JAX call: jit(step) from a Python loop; JAX scan: "
          "lax.scan(step), unroll 1; simulate: model.simulate (NSS: scan unrolled by 8; NFIR: "
          "all samples in parallel, not a recurrence); FMPy: FMUModel.step")
    print()
    for name, fl, nat, *_, diff, total in rows:
        print(f"{name}: native {fl / nat:.2f} GFLOP/s; native checksum {total:.15g} N = "
              f"FMUModel.predict's; max |force difference| FMU/scan vs simulate {diff:.1e} of "
              "the largest force")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
