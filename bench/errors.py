"""The bench's own error types: every error hil-bench raises on purpose derives from BenchError,
and its message is the one line to show (what, where, what to do). docs/api.md lists them.

    BenchError
     ├─ ArgumentError      a public function called with an argument it cannot take (also a
     │                     TypeError and a ValueError, so ``except TypeError`` still works)
     ├─ NoSuchFile         a file a call names is not there (also a FileNotFoundError)
 ├─ OutputIsInput      an output path that is one of the command's inputs (also a ValueError)
     ├─ ScenarioError      a scenario file or override (file, line, dotted field)
     ├─ LinkError          the link to the controller (spec, port, handshake, a dead controller)
     ├─ RunAborted         a run that could not start or continue
     ├─ RunFailed          a run that recorded no cycle (hil_bench.run)
     ├─ RecorderError      the recording could not be written (disk, folder, the recorder)
     ├─ RecordingError     a file that is not a readable recording of this bench
     ├─ ClaimsNotReproduced  Result.assert_claims (also an AssertionError)
     └─ NativeMissing      the compiled C is not built (also an ImportError)

Kept free of imports so that every module can use it.
"""
from __future__ import annotations


class BenchError(Exception):
    """Base of every error the bench raises on purpose; ``str(exc)`` says what, where and why."""


class ArgumentError(BenchError, TypeError, ValueError):
    """A public function got an argument it cannot take: the message names the argument, what it
    got and what it takes."""


class NoSuchFile(BenchError, FileNotFoundError):
    """A file a call names is not there (also a FileNotFoundError)."""


class OutputIsInput(BenchError, ValueError):
    """An output path names one of the command's own inputs (the same file by path, symbolic or
    hard link): refused with or without ``--force``."""


def did_you_mean(word: str, choices, n: int = 3) -> str:
    """``"; did you mean 'x'?"`` for the closest of ``choices`` (difflib), else ``""``."""
    import difflib

    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=n, cutoff=0.6)
    if not close:
        return ""
    return "; did you mean " + " or ".join(repr(c) for c in close) + "?"
