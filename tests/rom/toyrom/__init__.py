"""A toy ROM class defined outside ``src/``: the proof that a class is its package and one
registration (``sloshrom.rom.registry.register``), nothing else (tests/rom/test_toy_class.py).

``entry`` (its registry entry, no JAX), ``model`` (the fitted model, a JAX pytree) and
``estimator`` (least squares of a short FIR filter), as a class of ``sloshrom.rom`` is laid
out."""
