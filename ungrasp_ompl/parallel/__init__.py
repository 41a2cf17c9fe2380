"""Work taken to other processes: how a campaign runs (``options``: :class:`RunOptions`, its seed,
worker processes and cluster), runners that run tasks in worker processes on this machine or on a
Ray cluster (``runner``), and the rows of results streamed to a CSV file as they arrive, so that a
campaign resumes (``stream``)."""

from .options import RunOptions

__all__ = ["RunOptions"]
