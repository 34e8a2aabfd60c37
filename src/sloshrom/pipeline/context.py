"""What every stage of `sloshrom reproduce` gets: the output directory, the configuration and
the progress callback (:class:`Context`)."""

from __future__ import annotations

import threading
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from sloshrom.config import ConfigError, Tank
from sloshrom.pipeline.registry import study_tables
from sloshrom.pipeline.settings import ReproduceConfig, validate
from sloshrom.rig.virtual import RigParams, SensorParams, VirtualRig

__all__ = ["Context", "Progress", "StageEvents", "StageRecord", "check_rig_tanks", "in_thread",
           "no_events", "quiet"]

R = TypeVar("R")

#: Called as ``progress(stage, done, total, text)``; the CLI turns it into progress bars.
Progress = Callable[[str, float, float, str], None]

#: What a stage returns: its JSON-able outputs (its part of ``summary.json``) and the files it
#: wrote, relative to the output directory.
StageRecord = tuple[dict[str, Any], list[str]]

#: Called as ``on_stage(stage, event, seconds)``: ``event`` is ``"start"`` (the stage runs;
#: seconds 0), ``"done"`` (it finished; its wall time) or ``"reused"`` (found in the cache;
#: the time to check it). The CLI logs them when its output is not a terminal.
StageEvents = Callable[[str, str, float], None]


def in_thread(fn: Callable[[], R], name: str = "sloshrom-side") -> Future[R]:
    """``fn()`` started in a daemon thread: its result (or error) in the future. For a stage's
    work beside its own that writes nothing: a failure of the caller leaves it to end on its
    own."""
    future: Future[R] = Future()

    def run() -> None:
        try:
            future.set_result(fn())
        except BaseException as exc:
            future.set_exception(exc)

    threading.Thread(target=run, name=name, daemon=True).start()
    return future


def quiet(stage: str, done: float, total: float, text: str) -> None:
    """A :data:`Progress` that reports nothing."""


def no_events(stage: str, event: str, seconds: float) -> None:
    """A :data:`StageEvents` that reports nothing."""


@dataclass
class Context:
    """One run of the chain.

    Attributes
    ----------
    out : Path
        The output directory.
    cfg : ReproduceConfig
        The validated configuration (:func:`sloshrom.pipeline.settings.validate`; a dict of
        tables given here is validated into one).
    progress : Progress
        Progress callback.
    timings : dict
        Stage name -> wall time, s (filled by :func:`sloshrom.pipeline.run`).
    on_stage : StageEvents
        Told when each stage starts and ends, or is reused.
    """

    out: Path
    cfg: ReproduceConfig
    progress: Progress = quiet
    timings: dict[str, float] = field(default_factory=dict)
    on_stage: StageEvents = no_events

    def __post_init__(self) -> None:
        if isinstance(self.cfg, dict):  # built in code: typed here
            self.cfg = validate(self.cfg)

    @property
    def tank(self) -> Tank:
        """The run's tank (``[tank]`` of the configuration)."""
        return self.cfg.tank.tank()

    def rig_params(self) -> RigParams:
        """The rig's physics: the calibrated ``rig_params.toml`` with the ``[rig]`` overrides
        (``restitution``, ``beta``: ``sloshrom.pipeline.settings.OPTIONAL_KEYS``) applied."""
        changes = self.cfg.rig.overrides()
        return RigParams.default().replace(**changes)

    def rig(self, tank: Tank | None = None) -> VirtualRig:
        """The virtual rig of the configuration (physics :meth:`rig_params`); its sensors record
        at ``[rig] fs``. ``tank`` replaces the configured tank (another fill level)."""
        return VirtualRig(tank=self.tank if tank is None else tank, params=self.rig_params(),
                          seed=self.cfg.rig.seed,
                          sensors=SensorParams(output_fs=self.cfg.rig.fs))

    def path(self, *parts: str) -> Path:
        """``out/parts...``, its directory created."""
        p = self.out.joinpath(*parts)
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def rel(self, p: Path) -> str:
        """``p`` relative to the output directory, as listed in the stage's files."""
        return str(Path(p).relative_to(self.out))


def check_rig_tanks(cfg: ReproduceConfig) -> None:
    """Build the virtual rig at every tank the configuration runs it at, before any stage.

    The ``[tank]`` fill and every fill a registered study runs the rig at
    (:attr:`~sloshrom.pipeline.schema.StudyTable.rig_fills`: the fill family's, with
    ``[beyond] enabled``): a tank the rig cannot model (an extreme fill leaves none of its
    surface modes in its band) is refused here, naming the key, rather than when its stage
    starts after hours of others.

    Raises
    ------
    ConfigError
        The first key whose tank the rig refuses.
    """
    ctx = Context(Path("."), cfg)
    fills = [("tank.fill", float(ctx.cfg.tank.fill))]
    for t in study_tables():
        fills += t.rig_fills(ctx.cfg)
    for key, fill in fills:
        try:
            ctx.rig(ctx.tank.replace(fill=fill))
        except ConfigError as exc:
            raise ConfigError(f"'{key}' = {fill:g}: {exc}") from None
