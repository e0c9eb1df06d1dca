"""Running a meshing stage in a forked child under a time limit, so that a crash or a hang in
C++ becomes an exception."""

from __future__ import annotations

import os
import sys
import time

from ..errors import MeshingError

# --------------------------------------------------------------------------- child processes


class _TetGenFailed(Exception):
    """A mesher (TetGen, fTetWild) gave no mesh; ``str`` is its reason."""

    phase = None


class _TetGenCrashed(Exception):
    """The child process running a stage died; ``str`` says how, ``phase`` where (if known)."""

    phase = None


class _TetGenTimeout(_TetGenCrashed):
    """A stage ran past its time limit and its child was stopped."""


#: Run TetGen, the repair and fTetWild in forked child processes (Linux only). TetGen
#: can segfault on near-degenerate input, and its error path (a C++ exception thrown
#: from deep inside) can corrupt the heap of the process it runs in; in a child,
#: either becomes a :class:`MeshingError` and the caller's process is unharmed, and a
#: stage that runs too long can be stopped. It costs a fork and a copy of the result
#: (milliseconds). Set ``TETRACE_TETGEN_ISOLATE=0`` (or assign False here) to run
#: in-process, without time limits.
ISOLATE_TETGEN = (
    sys.platform.startswith("linux")
    and hasattr(os, "fork")
    and os.environ.get("TETRACE_TETGEN_ISOLATE", "1").strip().lower()
    not in ("0", "false", "no", "off")
)

# The file in the child's working folder its stdout and stderr go to.
_CHILD_LOG = "stage.log"


def _last_phase(text):
    """The last phase header in a TetGen log ("Recovering boundaries..."), or None."""
    phase = None
    for line in text.splitlines():
        s = line.rstrip()
        if s and not s[0].isspace() and s.endswith("..."):
            phase = s.rstrip(". ")
    return phase


def _call_forked(fn, *args, timeout=None):
    """Return ``fn(*args)`` computed in a forked child.

    The child's stdout and stderr go to a log file in its own working folder, which
    ``fn`` may write to; the last TetGen phase header found there is attached as
    ``.phase`` to the exceptions below. Re-raises the child's :class:`_TetGenFailed`
    and :class:`MeshingError`; raises :class:`_TetGenCrashed` when the child dies
    without answering and :class:`_TetGenTimeout` when it runs past ``timeout`` seconds.
    """
    import ctypes  # noqa: F401  (loaded before the fork; the child uses it)
    import pickle
    import select
    import signal
    import tempfile
    import warnings

    parent = os.getpid()
    # TetGen writes _skipped.node/.face into the working directory when it fails:
    # the child works in a folder of its own, removed afterwards.
    with tempfile.TemporaryDirectory(prefix="tetrace-mesher-") as workdir:
        log_path = os.path.join(workdir, _CHILD_LOG)
        read_fd, write_fd = os.pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        with warnings.catch_warnings():
            # Python >= 3.12 warns on fork in a threaded process; the child only runs
            # the mesher and numpy and never touches locks other threads may hold.
            warnings.simplefilter("ignore", DeprecationWarning)
            pid = os.fork()
        if pid == 0:  # child: never return into the caller's code
            try:
                os.close(read_fd)
                _child_setup(parent, workdir, log_path)
                try:
                    result = ("ok", fn(*args))
                except _TetGenFailed as exc:
                    result = ("failed", str(exc))
                except MeshingError as exc:
                    result = ("meshing", str(exc))
                except BaseException as exc:  # noqa: BLE001  (reported to the parent)
                    result = ("error", f"{type(exc).__name__}: {exc}")
                with os.fdopen(write_fd, "wb") as out:
                    out.write(pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))
            finally:
                os._exit(0)
        os.close(write_fd)
        deadline = None if timeout is None else time.monotonic() + timeout
        chunks = []
        try:
            while True:
                if deadline is not None:
                    left = deadline - time.monotonic()
                    if left <= 0:
                        raise _TetGenTimeout(f"stopped after {timeout:g} s")
                    if not select.select([read_fd], [], [], left)[0]:
                        continue
                chunk = os.read(read_fd, 1 << 22)
                if not chunk:
                    break
                chunks.append(chunk)
        except BaseException as exc:  # timeout or KeyboardInterrupt: stop the child too
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            if isinstance(exc, _TetGenCrashed):
                exc.phase = _read_phase(log_path)
            raise
        finally:
            os.close(read_fd)
        _, status = os.waitpid(pid, 0)
        phase = _read_phase(log_path)
    data = b"".join(chunks)
    if not data:
        if os.WIFSIGNALED(status):
            sig = os.WTERMSIG(status)
            try:
                how = f"killed by {signal.Signals(sig).name}"
            except ValueError:
                how = f"killed by signal {sig}"
        else:
            how = f"exit status {os.WEXITSTATUS(status)}"
        exc = _TetGenCrashed(how)
        exc.phase = phase
        raise exc
    kind, payload = pickle.loads(data)
    if kind == "meshing":
        raise MeshingError(payload)
    if kind in ("failed", "error"):
        exc = _TetGenFailed(
            payload if kind == "failed" else f"error in the child process: {payload}"
        )
        exc.phase = phase
        raise exc
    return payload


def _read_phase(path):
    try:
        with open(path, errors="replace") as fh:
            return _last_phase(fh.read())
    except OSError:
        return None


def _child_setup(parent, workdir, log_path):
    """Prepare a forked child: quiet on crashes, output to a log, bound to its parent's life."""
    # A crash is reported by the parent; no traceback dump from the child.
    import faulthandler

    faulthandler.disable()
    os.chdir(workdir)
    # C code (TetGen) prints to fd 1: send it to the log, line-buffered so the last
    # phase header is there even if the child is killed mid-phase.
    fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)
    try:
        import ctypes
        import signal

        libc = ctypes.CDLL(None)
        try:
            stdout = ctypes.c_void_p.in_dll(libc, "stdout")
            libc.setvbuf(stdout, None, 1, 0)  # _IOLBF
        except (ValueError, AttributeError):
            pass
        # Die with the parent (PR_SET_PDEATHSIG = 1), so a killed caller leaves no
        # mesher running on; if it already died, stop now.
        libc.prctl(1, int(signal.SIGKILL))
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(1)


def _run_stage(fn, *args, timeout=None, isolate=None):
    """Run ``fn(*args)`` in a forked child under ``timeout`` (or in-process when not isolating)."""
    if ISOLATE_TETGEN if isolate is None else isolate:
        return _call_forked(fn, *args, timeout=timeout)
    return fn(*args)


def _stage_message(stage, exc, timeout) -> str:
    """One line naming the stage, what happened and (TetGen) the phase it was in."""
    where = f" in TetGen's phase '{exc.phase}'" if getattr(exc, "phase", None) else ""
    if isinstance(exc, _TetGenTimeout):
        return (
            f"{stage} timed out: stopped after {timeout:g} s{where} (time limit: "
            f"timeout=, or TETRACE_TETGEN_TIMEOUT)"
        )
    if isinstance(exc, _TetGenCrashed):
        return f"{stage} crashed ({exc}){where}"
    return f"{stage} failed ({exc}){where}"
