"""The reproduce chain: configuration, cached stages, report."""

from sloshrom.pipeline.chain import Context, run

__all__ = ["Context", "run"]
