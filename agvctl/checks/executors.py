"""Where the runs of ``agvctl check``, ``agvctl fuzz`` and ``agvctl tune --pose`` go: one ``concurrent.futures``
executor — this thread, spawned local worker processes or a Dask cluster's — and the runs' outcomes gathered in the
order of their tasks, whatever order they finish in.

An interrupt (SIGINT, Ctrl-C) reaches only the parent process: the workers are started with it blocked, and the
parent stops them. Local workers run the numerical libraries on one thread each, so N workers on N cores do not
oversubscribe the machine.
"""

from __future__ import annotations

import contextlib
import importlib
import multiprocessing
import numbers
import os
import signal
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from multiprocessing import resource_tracker
from typing import Any, Literal, TypeVar

from agvctl.errors import ConfigError, caused_by_interrupt

__all__ = ["MAX_JOBS", "ExecutorKind", "InlineExecutor", "LocalPool", "execute", "open_executor", "resolved_jobs"]

ExecutorKind = Literal["local", "dask"]
T = TypeVar("T")
R = TypeVar("R")

_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


MAX_JOBS = 1024
"""The most worker processes a run may ask for: far beyond any machine's cores, far below what exhausts one."""


def resolved_jobs(
    jobs: int | None, executor: str, scheduler: str | None = None, progress: Callable[..., Any] | None = None
) -> int:
    """The number of local workers, with the options of a parallel run checked.

    Parameters
    ----------
    jobs : int or None
        Local worker processes, 1 to :data:`MAX_JOBS` (None: every core).
    executor : str
        ``"local"`` or ``"dask"``.
    scheduler : str or None
        A Dask scheduler's address (``tcp://host:8786``).
    progress : callable or None
        A progress function, checked to be one.

    Returns
    -------
    int
        The number of local workers.

    Raises
    ------
    ConfigError
        An option out of its range, in one line naming the option (``--jobs``, ``--executor``, ...).
    """
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, numbers.Integral)):
        raise ConfigError("--jobs", "", f"expected an integer (got {jobs!r})")
    n = int(jobs) if jobs is not None else (os.cpu_count() or 1)
    if not 1 <= n <= MAX_JOBS:
        raise ConfigError("--jobs", "", f"must be between 1 and {MAX_JOBS} (got {n})")
    if executor not in ("local", "dask"):
        raise ConfigError("--executor", "", f"must be local or dask (got {executor!r})")
    if scheduler is not None and not isinstance(scheduler, str):
        raise ConfigError("--scheduler", "", f"expected an address such as tcp://host:8786 (got {scheduler!r})")
    if progress is not None and not callable(progress):
        raise ConfigError("progress", "", f"expected a function progress(done, total) (got {progress!r})")
    return n


class InlineExecutor(Executor):
    """Each task run in this thread as it is submitted: no worker, so nothing to start and nothing left running
    after an interrupt (the run in progress stops with it)."""

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> Future[R]:
        future: Future[R] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # as a worker's: the task's error, in its future
            if caused_by_interrupt(exc):  # an interrupt that surfaced as another error stops the command
                raise
            future.set_exception(exc)
        return future


@contextlib.contextmanager
def _sigint_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread meanwhile (and delivered when the block ends): worker processes and threads
    started meanwhile inherit the block, so an interrupt (Ctrl-C reaches the whole process group) stops only this
    process, which then stops them."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


class LocalPool(ProcessPoolExecutor):
    """Spawned worker processes, all but one started when the pool opens; :attr:`ready` says when the first of them
    is up (with its ``prepare`` module imported), so that :func:`execute` runs tasks in this process until then.

    Parameters
    ----------
    jobs : int
        The worker processes.
    prepare : str or None
        A module each worker imports as it starts (None: none).
    """

    def __init__(self, jobs: int, prepare: str | None) -> None:
        self.used = False
        """Whether a task was submitted (a pool that got none is stopped without waiting for its start)."""
        self._warned = False
        # the tracker of multiprocessing's semaphores unblocks SIGINT in the thread that starts it: started first,
        # so that the block below holds while the workers and the pool's thread start (they inherit it)
        resource_tracker.ensure_running()
        spawn = multiprocessing.get_context("spawn")
        opened = False
        try:
            with _sigint_blocked():
                if prepare is None:
                    super().__init__(max_workers=jobs, mp_context=spawn)
                else:
                    super().__init__(jobs, spawn, initializer=importlib.import_module, initargs=(prepare,))
                opened = True
                # a submission that finds no idle worker starts one: all but one start now, this process being the
                # last while they start (no more busy processes than jobs); the last starts at the hand-over
                self._starts = [ProcessPoolExecutor.submit(self, int) for _ in range(max(1, jobs - 1))]
        except BaseException:  # an interrupt that arrived meanwhile: no worker outlives the pool
            if opened:
                self.stop()
                self.shutdown(wait=True, cancel_futures=True)
            raise

    @property
    def ready(self) -> bool:
        """Whether a worker is up (has started and imported the ``prepare`` module)."""
        return any(f.done() and not f.cancelled() and f.exception() is None for f in self._starts)

    @property
    def failure(self) -> BaseException | None:
        """Why the workers could not start, or None (the pool broke before it was given a task: a worker died,
        or a script without the ``if __name__ == "__main__":`` guard started processes as it was imported)."""
        for f in self._starts:
            if f.done() and not f.cancelled() and f.exception() is not None:
                return f.exception()
        return None

    def runs_here(self) -> bool:
        """Whether the next task had better run in the submitting process: until a worker is up, and always where
        the workers could not start (said once, as a warning)."""
        failure = self.failure
        if failure is not None and not self._warned:
            self._warned = True
            warnings.warn(
                f"the local worker processes could not start ({type(failure).__name__}); the runs go one after "
                "another in this process",
                RuntimeWarning,
                stacklevel=3,
            )
        return failure is not None or not self.ready

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> Future[R]:
        self.used = True
        return super().submit(fn, *args, **kwargs)

    def stop(self) -> None:
        """Terminate the workers at once (a run in progress is abandoned)."""
        for process in list(self._processes.values()):
            process.terminate()


@contextlib.contextmanager
def _process_pool(jobs: int, prepare: str | None) -> Iterator[Executor]:
    """``jobs`` spawned worker processes that never see SIGINT, started at once, terminated at once when the block
    is left by an exception or an interrupt (a run in progress is abandoned) or without having been given a task,
    and shut down otherwise. With ``prepare``, each imports that module as it starts."""
    # one thread per worker for the numerical libraries (as Dask does for its workers): with N workers on N cores
    # their own thread pools would oversubscribe the machine several times over
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    os.environ.update({k: "1" for k, v in saved.items() if v is None})
    try:
        pool = LocalPool(jobs, prepare)
        try:
            yield pool
        except BaseException:
            pool.stop()
            raise
        finally:
            if not pool.used:
                pool.stop()  # every task ran here while the workers started: do not wait for their start
            pool.shutdown(wait=True, cancel_futures=True)
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)


@contextlib.contextmanager
def open_executor(
    kind: ExecutorKind, jobs: int, scheduler: str | None, n_tasks: int, *, prepare: str | None = None
) -> Iterator[Executor]:
    """The executor the runs go to, shut down (its workers and any cluster of ours stopped) on leaving.

    An interrupt (SIGINT) reaches only this process; local workers are stopped with it.

    Parameters
    ----------
    kind : {'local', 'dask'}
        ``"local"``: ``jobs`` spawned worker processes (:class:`LocalPool`, started at once; :func:`execute` runs
        tasks in this process until the first of them is up), or, for one job or one task, this process itself
        (:class:`InlineExecutor`: no start-up cost; the runs go one after another). ``"dask"``: the
        ``concurrent.futures`` executor of a Dask client.
    jobs : int
        Local worker processes (with ``"dask"`` and no scheduler: the local cluster's).
    scheduler : str or None
        The Dask scheduler's address; None with ``"dask"``: a local cluster of ``jobs`` worker processes.
    n_tasks : int
        How many runs will be submitted (one runs in this process).
    prepare : str or None
        A module local workers import as they start (the one that holds the run function), so that their start-up
        overlaps what this process does before its first submission (drawing scenarios) and the tasks it runs
        itself meanwhile; a worker is up once it has imported it.

    Yields
    ------
    concurrent.futures.Executor
        The executor.

    Raises
    ------
    ConfigError
        ``"dask"`` without the dask extra installed.
    """
    if kind == "dask":
        try:
            from dask.distributed import Client
        except ImportError:
            raise ConfigError("--executor", "dask", "needs the dask extra: pip install 'agvctl[dask]'") from None
        # no scheduler: a local cluster of `jobs` worker processes
        client = Client(scheduler) if scheduler else Client(n_workers=jobs, threads_per_worker=1, processes=True)
        try:
            with client.get_executor(pure=False) as dask_pool:
                yield dask_pool
        finally:
            client.close()  # our own connection (and, without a scheduler, our own local cluster)
        return
    if jobs <= 1 or n_tasks <= 1:
        with InlineExecutor() as inline:
            yield inline
        return
    with _process_pool(jobs, prepare) as pool:
        yield pool


def execute(
    pool: Executor,
    run: Callable[[T], R],
    tasks: Sequence[T],
    progress: Callable[[int, int], None] | None,
    on_error: Callable[[T, Exception], R] | None = None,
) -> list[R]:
    """Run every task on an executor; the results in the order of the tasks, whatever order they finish in.

    On local workers (:class:`LocalPool`), this process runs the first tasks itself, one after another, until a
    worker is up, and hands the rest to the workers: a few runs finish before the workers would have started, and
    a long list loses nothing. Each run's result is its own wherever it runs.

    Parameters
    ----------
    pool : concurrent.futures.Executor
        The executor, from :func:`open_executor`.
    run : callable
        ``run(task)``: a module-level function (it is pickled for worker processes).
    tasks : sequence
        The tasks.
    progress : callable or None
        Called as ``progress(done, total)`` in this thread after each task.
    on_error : callable or None
        ``on_error(task, exception)`` gives the result of a task whose future raised (``run`` raised, or its
        worker died or could not send the result back); None: the first error stops all.

    Returns
    -------
    list
        One result per task, in their order.
    """
    outcomes: dict[Future[R], R] = {}

    def record(done: int, future: Future[R], task: T) -> None:
        try:
            outcomes[future] = future.result()
        except Exception as exc:
            if on_error is None:
                raise
            outcomes[future] = on_error(task, exc)
        if progress:
            progress(done, len(tasks))

    def here() -> bool:
        """Whether the next task runs in this process."""
        return pool.runs_here() if isinstance(pool, LocalPool) else isinstance(pool, InlineExecutor)

    futures: list[Future[R]] = []
    inline = InlineExecutor()
    for done, task in enumerate(tasks, start=1):  # each run in its turn, so progress comes run by run
        if not here():
            break
        futures.append(inline.submit(run, task))
        record(done, futures[-1], task)
    if len(futures) == len(tasks):
        return [outcomes[f] for f in futures]
    first = len(futures)
    with _sigint_blocked():  # worker processes started on a first submission inherit the block
        sent = [pool.submit(run, task) for task in tasks[first:]]
    task_of = dict(zip(sent, tasks[first:], strict=True))
    try:
        for done, future in enumerate(as_completed(sent), start=first + 1):
            record(done, future, task_of[future])
    finally:
        for future in sent:
            future.cancel()  # after an error or an interrupt: the runs not started yet
    return [outcomes[f] for f in futures + sent]
