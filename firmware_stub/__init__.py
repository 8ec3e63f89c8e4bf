"""hil_bench.firmware_stub: Python bindings to the portable controller C (firmware_stub/src:
estimators, FOC, protection, HIL session) that runs in the stub, on a DSP, and on the host as the
reference estimators (``estimators.REFERENCE_ESTIMATORS``)."""
