"""In-process work of an experiment done in a worker process beside its ROS runs (see :class:`InProcessWork`).

Why: an experiment alternates runs on the ROS graph (a simulator paced to the wall clock, a process per module)
with in-process runs (one process, as fast as the CPU allows). One after the other, each waits for the other; on
two cores they can share the machine. Jobs are module-level functions (they are pickled into the worker).
"""
from __future__ import annotations

import multiprocessing
from concurrent.futures import Future, ProcessPoolExecutor


class InProcessWork:
    """An experiment's in-process work (maps, in-process runs), one job after another in one worker process,
    beside the ROS runs the experiment makes meanwhile: on two cores it then costs little wall time of its own.
    In-process runs are deterministic for a seed: where they run does not change their figures. A ROS run that
    is judged on timing (the patrol robot's camera levels at 1x) should have the machine to itself: call
    :meth:`drain` before it."""

    def __init__(self, inline: bool = False) -> None:
        # spawn: a fresh interpreter, nothing of this process's state (matplotlib, open files) shared with it.
        # inline: every job runs at once in this process (tests whose jobs are stand-ins)
        self._pool = None if inline else ProcessPoolExecutor(max_workers=1,
                                                             mp_context=multiprocessing.get_context("spawn"))
        self._pending: list[Future] = []

    def submit(self, job, *args) -> Future:
        """`job(*args)` after the jobs given before it; its future holds what it returned or raised."""
        if self._pool is not None:
            future = self._pool.submit(job, *args)
        else:
            future = Future()
            try:
                future.set_result(job(*args))
            except Exception as error:  # kept in the future, as the worker's would be
                future.set_exception(error)
        self._pending.append(future)
        return future

    def busy(self) -> bool:
        """Whether a job given so far has not finished."""
        return not all(future.done() for future in self._pending)

    def drain(self) -> None:
        """Wait until every job given so far has finished (a job's error is raised by its own future)."""
        for future in self._pending:
            future.exception()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)


__all__ = ["InProcessWork"]
