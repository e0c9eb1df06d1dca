"""Progress reporting for the slow steps: one tqdm status line per meshing stage.

:meth:`tetrace.Scene.from_mesh` and :func:`tetrace.mesh.tetrahedralize` take ``progress``:

* ``None`` (the default): on when stderr is a terminal or the code runs in a Jupyter kernel,
  and never when the environment variable ``CI`` is set (to anything but ``""``, ``0``,
  ``false`` or ``no``);
* ``True`` / ``False``: on / off, whatever the environment.

While on, each stage (cleaning, a repair, each TetGen attempt with its preset, fTetWild, the
build of the compiled scene) writes one line to stderr with the seconds it has run, updated
twice a second while it runs (also while a mesher's child process works) and ending in
``done`` or ``failed``; ``mesher="auto"`` adds a bar counting its candidates. Nothing else
changes: the results are the same with progress on or off. tqdm is imported only when a
line is shown.

Ray queries (:meth:`tetrace.Scene.cast`, ``occluded``, ``intersections``,
``count_intersections``) take ``progress`` too: while on, a query that runs for more than
:data:`CAST_DELAY_S` seconds shows a bar of the rays done, updated by the core every 50 ms
as its chunks of 4096 rays finish (:func:`rays`); shorter ones show nothing.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import os
import sys
import threading
import time

__all__ = ["enabled", "reporting", "stage", "counter", "rays", "with_progress"]

# Whether the code running now reports progress (None: no caller decided).
_ACTIVE: contextvars.ContextVar[bool | None] = contextvars.ContextVar("tetrace_progress")

#: Seconds between refreshes of a running stage's line.
REFRESH_S = 0.5

#: Seconds a ray query runs before its bar appears (short casts stay silent).
CAST_DELAY_S = 1.0


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def _in_notebook() -> bool:
    shell = sys.modules.get("IPython")
    if shell is None:
        return False
    try:
        ip = shell.get_ipython()
    except Exception:  # noqa: BLE001  (any failure: not a notebook)
        return False
    return ip is not None and "ipykernel" in sys.modules and hasattr(ip, "kernel")


def enabled(progress=None) -> bool:
    """Whether ``progress`` turns progress reporting on.

    Parameters
    ----------
    progress : bool or None
        ``True``/``False`` force it; ``None`` decides from the environment: on when
        stderr is a terminal or in a Jupyter kernel, off when ``CI`` is set.

    Returns
    -------
    bool

    Raises
    ------
    TypeError
        ``progress`` is not None or a bool.
    """
    if progress is None:
        if _in_ci():
            return False
        try:
            tty = bool(sys.stderr.isatty())
        except (AttributeError, ValueError):
            tty = False
        return tty or _in_notebook()
    if isinstance(progress, bool) or type(progress).__name__ == "bool_":
        return bool(progress)
    raise TypeError(f"progress must be None, True or False, got {progress!r}")


@contextlib.contextmanager
def reporting(progress=None):
    """Report progress (or not) in the code run inside.

    Parameters
    ----------
    progress : bool or None
        As for :func:`enabled`; ``None`` inside an outer :func:`reporting` keeps the
        outer one's choice (``mesher="auto"`` meshing each candidate).

    Yields
    ------
    bool
        Whether progress is reported.
    """
    outer = _ACTIVE.get(None)
    if progress is None and outer is not None:
        yield outer
        return
    token = _ACTIVE.set(enabled(progress))
    try:
        yield _ACTIVE.get()
    finally:
        _ACTIVE.reset(token)


def with_progress(fn):
    """Run ``fn`` inside :func:`reporting` of its ``progress`` keyword argument."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with reporting(kwargs.get("progress")):
            return fn(*args, **kwargs)

    return wrapper


def _bar(desc, total=None):
    from tqdm.std import tqdm

    fmt = "{desc}" if total is None else "{desc}: {n_fmt}/{total_fmt} {postfix}"
    return tqdm(total=total, desc=desc, file=sys.stderr, bar_format=fmt, leave=True)


@contextlib.contextmanager
def stage(description):
    """One status line for a stage: ``description``, the seconds it has run, then ``done``
    or ``failed``; nothing when progress is off.

    Parameters
    ----------
    description : str
        What runs (``"TetGen attempt 1: preset 'quality', the scene as given"``).

    Yields
    ------
    None
    """
    if not _ACTIVE.get(None):
        yield
        return
    bar = _bar(f"{description}: 0.0 s")
    t0 = time.perf_counter()
    stop = threading.Event()

    def tick():
        while not stop.wait(REFRESH_S):
            bar.set_description_str(f"{description}: {time.perf_counter() - t0:.1f} s")

    thread = threading.Thread(target=tick, name="tetrace-progress", daemon=True)
    thread.start()
    outcome = "failed"
    try:
        yield
        outcome = "done"
    finally:
        stop.set()
        thread.join()
        bar.set_description_str(
            f"{description}: {time.perf_counter() - t0:.1f} s, {outcome}", refresh=False
        )
        bar.close()


class _NoCounter:
    def update(self, n=1):
        pass

    def set_postfix_str(self, s="", refresh=True):
        pass


@contextlib.contextmanager
def counter(description, total=None):
    """A bar counting items (``mesher="auto"``'s candidates); a no-op when progress is off.

    Parameters
    ----------
    description : str
    total : int, optional
        The most items there may be.

    Yields
    ------
    object
        Has ``update(n=1)`` and ``set_postfix_str(s)`` (a tqdm bar, or a no-op).
    """
    if not _ACTIVE.get(None):
        yield _NoCounter()
        return
    bar = _bar(description, total)
    try:
        yield bar
    finally:
        bar.close()


@contextlib.contextmanager
def rays(progress, n, description="casting"):
    """A bar of rays done for one ray query, or nothing when progress is off.

    Parameters
    ----------
    progress : bool or None
        As for :func:`enabled`.
    n : int
        Rays in the query.
    description : str
        What the query does.

    Yields
    ------
    callable or None
        ``report(done, total)``, which the core calls with the chunks done and their
        number; None when progress is off (the core then reports nothing). The bar shows
        only once the query has run :data:`CAST_DELAY_S` seconds, and ends at ``n`` when
        the query finishes.
    """
    if not enabled(progress) or n == 0:
        yield None
        return
    from tqdm.std import tqdm

    bar = tqdm(
        total=n,
        desc=description,
        unit="ray",
        unit_scale=True,
        file=sys.stderr,
        delay=CAST_DELAY_S,
        leave=True,
    )

    def report(done, total):
        bar.update(max(0, n * done // max(total, 1) - bar.n))

    try:
        yield report
        bar.update(n - bar.n)
    finally:
        bar.close()
