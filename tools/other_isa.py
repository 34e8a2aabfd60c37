"""Run a command as if on another CPU: the numerical libraries limited to an older instruction set.

Our stored references must hold on every CPU, and four libraries choose their code by the CPU at
run time, so the last bits of a result depend on the machine:

============ ============================================== ======================================
library      what changes with the CPU                      the setting used here
============ ============================================== ======================================
NumPy        AVX-512 and AVX2 loops of exp, log, power,     ``NPY_DISABLE_CPU_FEATURES="X86_V3
             tanh, arctan, ... (SVML)                       X86_V4"`` (NumPy >= 2.4 ignores the
                                                            old names such as ``AVX512F``)
glibc libm   FMA variants of exp, log, pow, sin (numba's    ``GLIBC_TUNABLES=glibc.cpu.hwcaps=
             kernels and NumPy's scalar loops call them)    -AVX2,-FMA,-AVX512F``
XLA          FMA in its own exp/tanh, vector widths         ``XLA_FLAGS=--xla_cpu_max_isa=AVX``
OpenBLAS     its kernels (FMA, block sizes, sum order)      ``OPENBLAS_CORETYPE=Sandybridge``
numba        code for the host CPU (vector registers);      ``NUMBA_CPU_NAME=generic``
             no FMA contraction without fastmath, so the
             same bits on every CPU
============ ============================================== ======================================

``python tools/other_isa.py check`` runs a probe with and without these settings in two fresh
processes and says, per library, whether its code path changed (exit code 1 if one that should
have did not). ``python tools/other_isa.py run -- CMD ...`` runs CMD with them.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys

SETTINGS = {
    "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4",
    "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F",
    "XLA_FLAGS": "--xla_cpu_max_isa=AVX",
    "OPENBLAS_CORETYPE": "Sandybridge",
    "NUMBA_CPU_NAME": "generic",
}


def other_isa_env(base: dict[str, str] | None = None) -> dict[str, str]:
    """``base`` (default: this process's environment) with the reduced instruction sets."""
    env = dict(os.environ if base is None else base)
    for key, value in SETTINGS.items():
        # keep the user's other XLA flags
        env[key] = f"{env[key]} {value}" if key == "XLA_FLAGS" and env.get(key) else value
    return env


def _digest(x) -> str:
    import numpy as np

    return hashlib.sha256(np.ascontiguousarray(x, dtype=np.float64).tobytes()).hexdigest()[:12]


def probe() -> dict[str, str]:
    """Fingerprints of each library's code path in this process."""
    import ctypes
    import glob
    import math

    import numpy as np

    x = np.linspace(-3.0, 40.0, 200_001)
    out = {"numpy": _digest(np.exp(x) + np.log1p(np.abs(x)) + np.tanh(x))}

    import numba

    @numba.njit
    def libm(v):
        r = np.empty_like(v)
        for i in range(v.size):
            r[i] = math.exp(v[i]) + math.log(1.0 + abs(v[i]))
        return r

    out["glibc libm (via numba)"] = _digest(libm(x))
    asm = libm.inspect_asm(libm.signatures[0])
    out["numba"] = (f"cpu={numba.config.CPU_NAME or 'host'} "
                    f"wide-registers={'ymm' in asm or 'zmm' in asm}")

    import jax
    import jax.numpy as jnp

    with jax.enable_x64(True):
        out["XLA"] = _digest(jnp.exp(jnp.asarray(x)) + jnp.tanh(jnp.asarray(x)))

    import numpy.linalg

    libs = glob.glob(os.path.join(os.path.dirname(np.__file__), "..", "numpy.libs",
                                  "*openblas*"))
    core = "unknown"
    for lib in libs:
        handle = ctypes.CDLL(lib)
        for name in ("scipy_openblas_get_corename64_", "openblas_get_corename"):
            fn = getattr(handle, name, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                core = fn().decode()
                break
    a = np.random.default_rng(0).standard_normal((200, 200))
    out["OpenBLAS"] = f"core={core} matmul={_digest(numpy.linalg.matmul(a, a))}"
    return out


def _run_probe(env: dict[str, str]) -> dict[str, str]:
    res = subprocess.run([sys.executable, __file__, "probe"], env=env, capture_output=True,
                         text=True, check=True)
    return json.loads(res.stdout)


#: the setting that must change each library's fingerprint, and the CPU flag it takes away
LIBRARIES = {
    "numpy": ("NPY_DISABLE_CPU_FEATURES", "avx2"),
    "glibc libm (via numba)": ("GLIBC_TUNABLES", "fma"),
    "numba": ("NUMBA_CPU_NAME", "avx2"),
    "XLA": ("XLA_FLAGS", "fma"),
    "OpenBLAS": ("OPENBLAS_CORETYPE", "avx2"),
}


def check() -> int:
    """Each library's fingerprint on the host and with its own setting alone; 1 if one ignores it.

    Each setting is applied alone, so that a library counts as changed by its own setting, not
    by another's (NumPy's scalar loops call glibc, for instance).
    """
    host_env = {k: v for k, v in os.environ.items() if k not in SETTINGS}
    host = _run_probe(host_env)
    cpu = open("/proc/cpuinfo").read().split() if os.path.exists("/proc/cpuinfo") else []
    failed = False
    for lib, (key, flag) in LIBRARIES.items():
        other = _run_probe({**host_env, key: other_isa_env(host_env)[key]})
        changed = host[lib] != other[lib]
        # a setting can only change the code where the host has what it takes away
        verdict = "changed" if changed else ("IGNORED" if flag in cpu else "same: host lacks it")
        print(f"{lib:24s} {key:25s} {verdict:20s} host: {host[lib]}  other: {other[lib]}")
        failed |= not changed and flag in cpu
    if failed:
        print("a library ignored its setting: the reference tests would not see another CPU")
    return int(failed)


def main(argv: list[str]) -> int:
    if argv[:1] == ["probe"]:
        print(json.dumps(probe()))
        return 0
    if argv[:1] == ["check"]:
        return check()
    if argv[:1] == ["run"] and len(argv) > 1:
        cmd = argv[2:] if argv[1] == "--" else argv[1:]
        return subprocess.run(cmd, env=other_isa_env()).returncode
    print(__doc__.strip().splitlines()[0], file=sys.stderr)
    print("usage: other_isa.py check | run -- CMD ...", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
