"""Run integrity: is a recording a complete, undamaged run over a clean link? (docs/protocol.md 6.9)

``check_integrity(rec, allow)`` returns an :class:`Integrity`: the list of problems, each either allowed
by the scenario (``[link] allow = {crc_errors = 5}``: up to 5) or not. An incomplete or damaged run never
passes: ``bench check --strict`` fails on any problem not allowed, and the claims of such a run are INVALID.
"""
from __future__ import annotations

#: Link counters of /link/stats that are problems when non-zero (docs/protocol.md 6.5, 6.9). The first
#: eight are counted today; the others by the host's cycle engine (absent counters read as 0).
LINK_COUNTERS: tuple[str, ...] = (
    "crc_errors", "cobs_errors", "length_errors", "overruns", "bytes_discarded", "seq_mismatch",
    "telem_missing", "unknown_ids",
    "duplicates", "retries", "rows_dropped", "late_duty", "missed_duty", "estimator_mismatch", "bad_duties",
)
