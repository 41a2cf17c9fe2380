"""How a campaign runs: the seed of its random streams, its worker processes and where they run.

:class:`RunOptions` is the one options object for that concern: the workflows' and campaigns'
options nest it (``SimulateOptions.run``, ``MapOptions.run`` ...) and pass it whole to what runs
their work (sim.campaign.simulate, the benchmarks' runners).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError
from .runner import default_jobs


def check_seed(seed: object) -> int:
    """seed, an integer in [0, 2^32) (OMPL's and numpy's seeds); InputError naming `seed` otherwise."""
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
        raise InputError("seed", f"must be an integer in [0, 2^32), got {seed!r}")
    return seed


@dataclass(frozen=True)
class RunOptions:
    """The seed, the worker processes and the place a campaign runs with."""

    seed: int = 1
    """Seed of the run's random streams (an integer in [0, 2^32)): the trials' errors, the
    campaign's draws (a benchmark's run k is seeded with seed + k)."""
    jobs: int | None = None
    """Worker processes (count, >= 1); None: all cores (default_jobs). Unused on a cluster."""
    cluster: str | None = None
    """A Ray cluster's address ("local" starts one here); None: this machine."""

    @property
    def workers(self) -> int:
        """The worker processes the run uses (count): jobs, or all cores when None."""
        return default_jobs() if self.jobs is None else self.jobs

    def validated(self) -> "RunOptions":
        """These options checked; InputError naming `jobs` or `seed` otherwise."""
        jobs = self.jobs
        if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
            raise InputError("jobs", f"must be a positive integer, got {jobs!r}")
        check_seed(self.seed)
        return self
