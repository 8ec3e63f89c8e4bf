"""How the suite may run in parallel (``make test-py``: pytest-xdist, ``-n auto --dist loadgroup``).

Every test runs beside another: temporary folders (tmp_path) and free ports (port 0) of its own.
Two kinds of tests are kept together on one worker (an ``xdist_group``), one after the other:

* ``@pytest.mark.real_time``: a test that measures the machine in real time (the plant paced
  by the wall clock: loop closing, misses, jitter). They share one worker so that no two of
  them compete for the CPUs; the other worker goes on with lockstep tests beside them, so each
  such test also measures whether the machine keeps real time right now and skips, with the
  figures, when it does not (tests/real_time_floor.py). Lateness is what they measure: they
  never get a longer deadline.
* the tests of a module that share a module-scoped fixture defined in that module (a recorded
  run, a QEMU run, a report): the fixture is made once, on one worker, instead of once on each.
"""
from __future__ import annotations

import pytest

REAL_TIME_GROUP = "real_time"


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "real_time: the test runs the plant in real time and measures the machine; "
                   "pytest-xdist keeps all of them on one worker (tests/conftest.py)")


def _shares_a_module_fixture(item: pytest.Item) -> bool:
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return False
    for defs in info.name2fixturedefs.values():
        for fixturedef in defs:
            if fixturedef.scope in ("module", "class", "package") and \
                    getattr(fixturedef, "baseid", "").startswith(item.nodeid.split("::")[0]):
                return True
    return False


@pytest.hookimpl(tryfirst=True)   # before pytest-xdist's own hook reads the groups
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if item.get_closest_marker("xdist_group") is not None:
            continue
        if item.get_closest_marker("real_time") is not None:
            item.add_marker(pytest.mark.xdist_group(REAL_TIME_GROUP))
        elif _shares_a_module_fixture(item):
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
