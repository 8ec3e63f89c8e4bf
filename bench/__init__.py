"""hil_bench: a hardware-in-the-loop bench for sensorless PMSM motor-control firmware.

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
command line is ``bench`` (``hil_bench.cli``).
"""
