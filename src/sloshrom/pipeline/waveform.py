"""Waveform fidelity in `sloshrom reproduce`: the ROM's force against the rig's, beside the rig's
twin run (docs/rom.md, "Waveform fidelity").

The rig is deterministic but chaotic: a test played again with its input's gain changed by
``[rig] twin_gain`` (1.001 = +0.1 %, less than any laboratory's shaker or amplifier holds) gives a
force that a laboratory could not tell from the nominal one, yet differs from it point by point.
Its figures against the nominal run (:func:`sloshrom.fidelity.waveform_fidelity`) are the scale
of what a measurement could confirm, set beside the ROM's:

- the ``rom`` stage: the validation record (:func:`validation_fidelity`; the twin record from
  :func:`sloshrom.pipeline.data.replay_record`);
- the ``beam`` stage: the random tests at each level (:func:`random_fidelity`), the rig coupled
  to the beam with the base excitation times the gain (``sloshrom.pipeline.beam.beam_tests``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from sloshrom.fidelity import Figures, waveform_fidelity

__all__ = ["FREE_SECONDS", "free_fidelity", "random_fidelity", "validation_fidelity"]

#: The free decay's first seconds judged (paper Fig. 20c: the violent impacts after the release)
FREE_SECONDS = 2.0


def _forces(result: Mapping[str, object]) -> tuple[np.ndarray, float]:
    """A beam run's dynamic force, N, (levels, n), and its rate, Hz."""
    return (np.atleast_2d(np.asarray(result["dynamic_force"], dtype=np.float64)),
            float(np.asarray(result["fs"], dtype=np.float64)))


def validation_fidelity(reference: np.ndarray, model: np.ndarray, twin: np.ndarray, fs: float,
                        gain: float, seconds: float) -> dict[str, float | Figures]:
    """The waveform figures of the ROM's validation prediction and of the rig's twin run.

    Parameters
    ----------
    reference : ndarray
        The validation record's dynamic force, N.
    model : ndarray
        The ROM's free-run prediction of it, N.
    twin : ndarray
        The record's dynamic force from the rig with the input times ``gain``, N.
    fs : float
        The record rate, Hz.
    gain, seconds : float
        The twin's gain (-) and the time of its rig run (s), recorded beside the figures.

    Returns
    -------
    dict
        ``twin_gain`` (-), ``twin_seconds`` (s), ``rom`` and ``twin``: each
        :func:`sloshrom.fidelity.waveform_fidelity` against the record.
    """
    return {"twin_gain": float(gain), "twin_seconds": float(seconds),
            "rom": waveform_fidelity(reference, model, fs),
            "twin": waveform_fidelity(reference, twin, fs)}


def random_fidelity(results: Mapping[str, Mapping[str, object]], twin: Mapping[str, object],
                    levels: Sequence[float], gain: float, seconds: float
                    ) -> dict[str, float | dict[str, dict[str, Figures]]]:
    """The waveform figures of the beam's random tests, level by level.

    Parameters
    ----------
    results : mapping
        Case -> the random tests' result dict (``"rig"`` the reference; ``"rom"``, if present,
        judged against it): ``dynamic_force`` (N, shape (levels, n)) at ``fs`` (Hz).
    twin : mapping
        The rig's twin run (the same tests, base excitation times ``gain``), same shape and
        rate.
    levels : sequence of float
        The RMS levels, g.
    gain, seconds : float
        The twin's gain (-) and the time of its run (s), recorded beside the figures.

    Returns
    -------
    dict
        ``twin_gain``, ``twin_seconds`` and ``levels``: per level (g, as text) ``twin`` and, with
        a ROM, ``rom``, each :func:`sloshrom.fidelity.waveform_fidelity` against the rig.
    """
    ref, _ = _forces(results["rig"])
    others = {"twin": _forces(twin),
              **({"rom": _forces(results["rom"])} if "rom" in results else {})}
    per_level: dict[str, dict[str, Figures]] = {}
    for j, level in enumerate(levels):
        per_level[f"{level:g}"] = {case: waveform_fidelity(ref[j], force[j], fs)
                                   for case, (force, fs) in others.items()}
    return {"twin_gain": float(gain), "twin_seconds": float(seconds), "levels": per_level}


def free_fidelity(results: Mapping[str, Mapping[str, object]], seconds: float = FREE_SECONDS
                  ) -> dict[str, float | Figures]:
    """The waveform figures of the ROM's free decay over its first ``seconds`` (paper Fig.
    20c), against the rig's.

    Parameters
    ----------
    results : mapping
        Case -> the free decay's result dict (``"rig"`` the reference, ``"rom"`` judged):
        ``dynamic_force`` (N, shape (n,)) at ``fs`` (Hz).
    seconds : float
        The window judged, s.

    Returns
    -------
    dict
        ``seconds`` and, with a ROM, ``rom``: :func:`sloshrom.fidelity.waveform_fidelity`
        against the rig over the window.
    """
    out: dict[str, float | Figures] = {"seconds": float(seconds)}
    if "rom" not in results:
        return out
    ref, fs = _forces(results["rig"])
    rom, _ = _forces(results["rom"])
    n = min(ref.shape[-1], int(round(seconds * fs)) + 1)
    out["rom"] = waveform_fidelity(ref[0, :n], rom[0, :n], fs)
    return out
