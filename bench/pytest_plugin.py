"""pytest plugin (entry point ``pytest11``, loaded wherever hil-bench is installed): a drive team's
tests run scenarios against its controller, in CI against the bundled stub and on the bench
against the drive, with the same tests (docs/api.md, examples/firmware_ci/)::

    def test_startup_reproduces_gong(hil_run):
        result = hil_run("gong_g2_500rpm")
        result.assert_claims()              # fails with the paper-vs-measured table

    pytest                                                # the bundled C stub on a pty
    pytest --hil-link serial:/dev/ttyUSB0@3000000         # the drive on the bench
    pytest --hil-link can                                 # python-can's own configuration

Options: ``--hil-link SPEC`` (default: ini ``hil_link``, else ``stub``), ``--hil-stub PATH`` (the
stub executable: a team's own host build of its firmware; default the bundled one or
$HIL_STUB), ``--hil-recordings DIR`` (default: ``hil-recordings/`` in pytest's temporary
folder). Fixtures: ``hil_link`` (the link spec, session-wide) and ``hil_run`` (a function that
runs a scenario on it and returns a :class:`hil_bench.Result`). Every run's measured values go
into the JUnit XML as properties (``<scenario>/<quantity>/measured``, ``.../verdict``, ...: the
test's user_properties, as record_property does), with ``<scenario>/controller``: the
controller that answered, from its HELLO_ACK as recorded, not the link spec; a failed test's
report names its recordings. A link spec given but empty (``--hil-link "$HIL_LINK"`` with the
variable unset) or unknown is a usage error, never a silent run on the stub. Marker
``@pytest.mark.hil_drive``: the test runs only when the link is a real drive (``serial:...``,
``can...``), and is skipped on the bundled stub, SIL and pil-qemu.
"""
from __future__ import annotations

import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

_RECORDINGS = pytest.StashKey[list]()


@dataclass(frozen=True)
class HilLink:
    """The controller the session's runs talk to (``--hil-link``)."""

    spec: str

    @property
    def is_stub(self) -> bool:
        """The bundled firmware stub (on any of its links), not a real drive."""
        return self.spec == "stub" or self.spec.startswith("stub-")

    @property
    def is_drive(self) -> bool:
        """A controller the bench did not start, on a serial port or a CAN interface (a real
        drive); not the bundled stub, SIL or the firmware under QEMU (pil-qemu)."""
        kind = re.split(r"[:@,]", self.spec, maxsplit=1)[0]
        return kind in ("serial", "can")

    def __str__(self) -> str:
        return self.spec


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("hil-bench", "hil-bench: scenarios against a motor controller")
    group.addoption("--hil-link", default=None, metavar="SPEC",
                    help="the controller under test, as `bench run --link`: stub (the bundled C "
                         "firmware stub, the default), stub-slcan, serial:/dev/ttyUSB0@3000000, "
                         "can:<interface>:<channel>[@bitrate], can (python-can's configuration)")
    group.addoption("--hil-stub", default=None, metavar="PATH",
                    help="the stub executable for the stub links (default: $HIL_STUB, else the "
                         "one hil-bench ships)")
    group.addoption("--hil-recordings", default=None, metavar="DIR",
                    help="where runs record (default: hil-recordings/ in pytest's basetemp)")
    # "" (unset): --hil-link's own default, stub
    parser.addini("hil_link", "default of --hil-link (unset: stub)", default="")


MARKER = ("hil_drive: the test needs a real drive (--hil-link serial:... or can...); skipped on "
          "the bundled stub, SIL and pil-qemu")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", MARKER)
    stub = config.getoption("--hil-stub")
    if stub:
        # read by the stub launcher (hil_bench.installation.find_executable) in this process
        os.environ["HIL_STUB"] = str(Path(stub).resolve())
    if _uses_link(config):
        from hil_bench.loop.links import LinkError, check_link_spec

        given = config.getoption("--hil-link")
        try:   # an empty or unknown link is one clear error, before any test runs
            check_link_spec(_link(config).spec,
                            option="--hil-link" if given is not None else "ini hil_link")
        except LinkError as exc:
            raise pytest.UsageError(str(exc)) from None


def _uses_link(config: pytest.Config) -> bool:
    """The session names a link (the option, even empty, or the ini value)."""
    return config.getoption("--hil-link") is not None or bool(config.getini("hil_link"))


def _link(config: pytest.Config) -> HilLink:
    given = config.getoption("--hil-link")
    if given is not None:
        return HilLink(given)          # as given: an empty one is refused, not read as stub
    return HilLink(config.getini("hil_link") or "stub")


def pytest_runtest_setup(item: pytest.Item) -> None:
    if item.get_closest_marker("hil_drive") is None:
        return
    link = _link(item.config)
    if not link.is_drive:
        pytest.skip(f"needs a real drive (--hil-link serial:<port> or can:...); this session's "
                    f"link is {link.spec} (bundled)")


def pytest_report_header(config: pytest.Config) -> list[str] | None:
    if not _uses_hil(config):
        return None
    from hil_bench.installation import version

    link = _link(config)
    what = link.spec
    if link.is_stub:
        try:
            from hil_bench.installation import find_executable

            what += f" ({find_executable('hil_stub', env='HIL_STUB')})"
        except FileNotFoundError as exc:
            what += f" (not found: {exc})"
    return [f"hil-bench {version()}: link {what}"]


def _uses_hil(config: pytest.Config) -> bool:
    """Only sessions that ask for it get the header (every session loads the plugin)."""
    return _uses_link(config) or any(config.getoption(o) for o in ("--hil-stub",
                                                                   "--hil-recordings"))


@pytest.fixture(scope="session")
def hil_link(pytestconfig: pytest.Config) -> HilLink:
    """The link spec of this session's runs (``--hil-link``; ``.is_stub`` for the bundled stub)."""
    return _link(pytestconfig)


@pytest.fixture(scope="session")
def hil_recordings(pytestconfig: pytest.Config, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder the session's recordings go to (``--hil-recordings``)."""
    given = pytestconfig.getoption("--hil-recordings")
    if given:
        path = Path(given)
        path.mkdir(parents=True, exist_ok=True)
        return path
    return tmp_path_factory.mktemp("hil-recordings", numbered=False)


_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")
#: ``allow_slow_link`` of the fixtures' runs unless a test says otherwise: a lockstep run on a link
#: slower than its scenario's rate (G2's 10 kHz on a drive's 3 Mbaud UART) runs slower than real
#: time and records the same rows (bench run --allow-slow-link); a real-time run is refused as ever
SLOW_LINK_ALLOWED = True


@pytest.fixture
def hil_run(request: pytest.FixtureRequest, hil_link: HilLink,
            hil_recordings: Path) -> Callable[..., Any]:
    """``hil_run(scenario, overrides=None, **kwargs) -> hil_bench.Result``: run a scenario on
    ``hil_link``, record it under ``hil_recordings`` (named after the test), check it; its
    measured values become JUnit XML properties. Keyword arguments are ``hil_bench.run``'s
    (``allow_slow_link`` True unless given: SLOW_LINK_ALLOWED)."""
    from hil_bench.api import run

    stem = _UNSAFE.sub("_", request.node.nodeid).strip("_")[-120:]
    count = [0]

    def _run(scenario: str | Path, overrides: Mapping[str, Any] | None = None,
             **kwargs: Any) -> Any:
        count[0] += 1
        out = kwargs.pop("out", None) or hil_recordings / f"{stem}-{count[0]}.mcap"
        request.node.stash.setdefault(_RECORDINGS, []).append(Path(out))
        kwargs.setdefault("allow_slow_link", SLOW_LINK_ALLOWED)
        result = run(scenario, link=kwargs.pop("link", hil_link.spec), overrides=overrides,
                     out=out, force=kwargs.pop("force", True), **kwargs)
        _record(request.node.user_properties, result)
        return result

    return _run


@pytest.fixture
def hil_session(request: pytest.FixtureRequest, hil_link: HilLink,
                hil_recordings: Path) -> Callable[..., Any]:
    """``hil_session(scenario, overrides=None, **kwargs) -> hil_bench.Session``: a scripted
    lockstep run on ``hil_link``, recorded under ``hil_recordings`` (named after the test);
    keyword arguments are ``hil_bench.Session``'s. A session the test leaves open is closed at
    its end: run to its end and checked if the test passed (its figures become JUnit XML
    properties, as ``hil_run``'s), ended where it holds if the test failed (the recording kept,
    named in the report)."""
    from hil_bench.session import Session

    stem = _UNSAFE.sub("_", request.node.nodeid).strip("_")[-120:]
    sessions: list[Any] = []
    failed_before = request.session.testsfailed

    def _open(scenario: str | Path, overrides: Mapping[str, Any] | None = None,
              **kwargs: Any) -> Any:
        out = kwargs.pop("out", None) or hil_recordings / f"{stem}-s{len(sessions) + 1}.mcap"
        request.node.stash.setdefault(_RECORDINGS, []).append(Path(out))
        kwargs.setdefault("allow_slow_link", SLOW_LINK_ALLOWED)
        s = Session(scenario, link=kwargs.pop("link", hil_link.spec), overrides=overrides,
                    out=out, force=kwargs.pop("force", True), **kwargs)
        sessions.append(s)
        return s

    yield _open
    failed = request.session.testsfailed > failed_before
    for s in sessions:
        if not s.closed:
            if failed:
                s.stop("the test failed")
            else:
                s.close()
        if s.result is not None:
            _record(request.node.user_properties, s.result)


def _record(user_properties: list, result: Any) -> None:
    """The run's figures as JUnit XML properties, prefixed with the scenario's name: what the
    ``record_property`` fixture does, without its warning per test under junit_family xunit2
    (pytest writes the properties for every family; xunit2's schema has no place for them:
    junit_family = "xunit1" gives a file that validates)."""

    def record_property(name: str, value: object) -> None:
        user_properties.append((name, value))

    pre = result.scenario
    record_property(f"{pre}/recording", str(result.recording))
    # who answered (its HELLO_ACK, as recorded), not the link string the run was given
    record_property(f"{pre}/controller", getattr(result, "controller", "") or "none answered")
    record_property(f"{pre}/integrity", "ok" if result.integrity.ok
                    else "; ".join(result.integrity.problems) or "not ok")
    if result.run is not None and result.run.error:
        record_property(f"{pre}/run_error", result.run.error)
    for c in result.claims:
        key = f"{pre}/{c.quantity}"
        record_property(f"{key}/measured", c.measured)
        record_property(f"{key}/paper", c.paper)
        record_property(f"{key}/unit", c.unit)
        record_property(f"{key}/rule", c.rule)
        record_property(f"{key}/verdict", c.verdict + (" (diagnostic)" if c.diagnostic else ""))
    for name, value in result.metrics.items():
        record_property(f"{pre}/metrics/{name}", value)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    outcome = yield
    report = outcome.get_result()
    paths = item.stash.get(_RECORDINGS, None)
    if paths and report.failed:
        lines = [f"{p}" + ("" if p.exists() else " (not written)") for p in paths]
        report.sections.append(("hil-bench recordings", "\n".join(lines)))
