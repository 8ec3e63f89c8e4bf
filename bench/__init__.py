"""hil_bench: a hardware-in-the-loop bench for sensorless PMSM motor-control firmware.

The Python API (docs/api.md), imported on first use so that ``import hil_bench`` stays cheap::

    hil_bench.run(scenario, link="stub", overrides={...})  -> Result (metrics, claims, integrity,
                                                              recording path)
    hil_bench.check(path)                                 -> Result of a recording
    hil_bench.load_recording(path)                        -> each channel as a pandas DataFrame
    hil_bench.Session(scenario, link="stub", ...)         -> a scripted lockstep run, step by step
    hil_bench.signals                                     -> settling, overshoot, band, step, ramp,
                                                             frequency checks on recorded signals
    hil_bench.__version__

The data path, one sub-package per stage (docs/architecture.md, "The house")::

    scenario/   what to run: scenario files, their faults, typed located errors
    loop/       closing the loop: runner, links, host session, faults as engine events
    record/     MCAP recordings: channels, recorder, reader, recover, integrity, fault outcomes
    papers/     the papers' claims: metrics, claims, bench check, studies, the claims report
    faults/     fault campaigns
    replay/     replaying captures; conformance: a controller against the protocol spec
    perf/       benchmarks

and beneath them the plant and cycle engine (``hil_bench.plant_rt``), the wire format
(``hil_bench.protocol``) and the portable controller C (``hil_bench.firmware_stub``). The
command line is ``bench`` (``hil_bench.cli``); the pytest plugin ``hil_bench.pytest_plugin``;
``hil_bench.installation`` says where the compiled parts are.
"""
from __future__ import annotations

TYPE_CHECKING = False   # typing itself is not imported: `import hil_bench` stays cheap

if TYPE_CHECKING:
    from hil_bench import signals
    from hil_bench.session import (
        ConditionNotMet,
        InputRefused,
        Session,
        SessionError,
        SessionTimeout,
    )
    from hil_bench.api import (
        ArgumentError,
        BenchError,
        ClaimsNotReproduced,
        ClaimTable,
        ClaimVerdict,
        Integrity,
        NoSuchFile,
        OutputIsInput,
        RecordingData,
        Result,
        RunFailed,
        RunInfo,
        check,
        load_recording,
        run,
    )

#: the API's names, each imported from hil_bench.api on first use
_API = ("run", "check", "load_recording", "Result", "RunInfo", "ClaimVerdict", "ClaimTable",
        "Integrity", "RecordingData", "ClaimsNotReproduced", "RunFailed", "BenchError",
        "ArgumentError", "NoSuchFile", "OutputIsInput")
#: scripted tests' names, from hil_bench.session on first use; and the signal checks' module
_SESSION = ("Session", "SessionError", "SessionTimeout", "InputRefused", "ConditionNotMet")
__all__ = [*_API, *_SESSION, "signals", "__version__"]


def __getattr__(name: str):
    if name in _API or name in _SESSION:
        if name in _API:
            from hil_bench import api as module
        else:
            from hil_bench import session as module

        value = getattr(module, name)
        globals()[name] = value          # once: later lookups are plain attribute reads
        return value
    if name == "signals":
        import importlib

        return importlib.import_module("hil_bench.signals")
    if name == "__version__":
        from hil_bench.installation import version

        return version()
    raise AttributeError(f"module 'hil_bench' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
