"""The live view's command-line options (bench run, bench replay; docs/foxglove.md): --live,
--live-rate, --live-host, --live-wait as LiveOptions, and what the bench says when it listens."""
from __future__ import annotations

import argparse

from rich.markup import escape


def live_options(args: argparse.Namespace, err):
    """--live, --live-rate, --live-host, --live-wait (bench run, bench replay) as LiveOptions,
    or None; --live-host and --live-wait imply --live. A host beyond loopback is warned about.
    ValueError names a bad option."""
    host = getattr(args, "live_host", None)
    wait_s = getattr(args, "live_wait", None)
    port = args.live
    if port is None and (host is not None or wait_s is not None):
        from hil_bench.record.live_view import DEFAULT_PORT

        port = DEFAULT_PORT
    if port is None:
        return None
    from hil_bench.record.live_view import DEFAULT_HOST, LiveOptions, host_warning

    live = LiveOptions(port=port, rate_hz=args.live_rate,
                       host=host if host is not None else DEFAULT_HOST,
                       wait_s=wait_s)
    warning = host_warning(live.host)
    if warning:
        err.print(f"[yellow]warning:[/yellow] {escape(warning)}")
    return live


def said_listening(err, live, port: int) -> None:
    """Where the live view listens (and, with --live-wait, that the run waits for a viewer)."""
    from hil_bench.record.live_view import listening_line, waiting_line

    err.print(escape(listening_line(port, live.host)))
    if live.wait_s is not None:
        err.print(escape(waiting_line(port, live.host, live.wait_s)))


def add_live_hand_options(p: argparse.ArgumentParser, what: str) -> None:
    """--live-host and --live-wait (bench run, bench replay; docs/foxglove.md)."""
    from hil_bench.record.live_defaults import DEFAULT_WAIT_S

    p.add_argument("--live-host", default=None, metavar="ADDR",
                   help="--live: the address to listen on (default 127.0.0.1, this machine "
                        "only; 0.0.0.0: every interface, with a warning); implies --live")
    p.add_argument("--live-wait", type=float, nargs="?", const=DEFAULT_WAIT_S, default=None,
                   metavar="TIMEOUT_S",
                   help=f"--live: start the {what} when the first viewer subscribes, waiting at "
                        f"most TIMEOUT_S (default {DEFAULT_WAIT_S:g} s; none by then: an "
                        f"error); implies --live")
