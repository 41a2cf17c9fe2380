"""Work taken to other processes: runners that run tasks in worker processes on this machine or
on a Ray cluster (``runner``), and the rows of results streamed to a CSV file as they arrive, so
that a campaign resumes (``stream``)."""

__all__: list[str] = []  # nothing public: the workflows and campaigns take jobs and a cluster's address
