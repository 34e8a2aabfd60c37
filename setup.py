"""The package's one compiled extension: the grey box's training kernel (an XLA FFI handler).

Everything else is in pyproject.toml. The extension is optional: without a C++ compiler, or
without jaxlib's FFI headers at build time (an isolated build that does not install jaxlib),
the package installs without it and the grey box trains by its pure-JAX path.
"""

from setuptools import Extension, setup


def _kernel() -> list[Extension]:
    try:
        import jax.ffi
    except ImportError:
        return []
    # -O3 auto-vectorises for the baseline ISA; window.cc adds clones for x86-64-v3 and v4 that
    # the loader picks by CPU (no -march: the binary runs on any x86-64); -g0 drops the -g of
    # Python's CFLAGS: the same code, without the debug information that took 4-5 s of 17
    return [Extension("sloshrom.rom.grey._window", ["src/sloshrom/rom/grey/window.cc"],
                      include_dirs=[jax.ffi.include_dir()], language="c++", optional=True,
                      extra_compile_args=["-O3", "-g0", "-std=c++17", "-fvisibility=hidden"])]


setup(ext_modules=_kernel())
