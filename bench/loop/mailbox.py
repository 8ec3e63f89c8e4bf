"""A script's side of the engine's mailbox (plant_rt/c/live.h): inputs pushed, answers and holds
waited for. hil_bench.Session drives a lockstep run with it; the engine takes each input at the
start of a cycle and answers it (applied, or refused with the reason) on the mailbox.

The waits sleep in C on the mailbox's futex word with the GIL released, in slices of
``SLICE_S`` of wall time, so the caller can look at the engine, the recorder and its own
wall-clock bound between them (and Ctrl-C reaches Python). The slices decide only how soon a
dead engine is noticed, never what the run does.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

from hil_bench.plant_rt._plant_c import ffi, lib

#: one wait in C at most this long [s] (then the caller looks around and waits again)
SLICE_S = 0.05

HOLD_AT = int(lib.LIVE_IN_HOLD_AT)
SPEED_REF = int(lib.LIVE_IN_SPEED_REF)
IQ_REF = int(lib.LIVE_IN_IQ_REF)
ID_REF = int(lib.LIVE_IN_ID_REF)
CONTROL_MODE = int(lib.LIVE_IN_CONTROL_MODE)
LOAD = int(lib.LIVE_IN_LOAD)
FAULT_ON = int(lib.LIVE_IN_FAULT_ON)
FAULT_OFF = int(lib.LIVE_IN_FAULT_OFF)
NOTE = int(lib.LIVE_IN_NOTE)


class MailboxFull(RuntimeError):
    """Every slot holds an input the engine has not taken (it is not holding)."""


@dataclass(frozen=True)
class News:
    """What the engine last said: the cycle it holds before (-1: it runs), inputs answered and
    refused, and the last refusal's text."""

    word: int
    held_k: int
    answered: int
    refused: int


class ScriptMailbox:
    """The script's end of a formatted mailbox mapping (bench/loop/runner.py new_live_inbox)."""

    def __init__(self, mem):
        self._mem = mem
        self._box = lib.live_inbox_attach(ffi.from_buffer(mem), len(mem))
        if self._box == ffi.NULL:
            raise ValueError("the engine's mailbox is not formatted")
        self._args = ffi.new("int32_t[4]")
        self._held = ffi.new("int64_t *")
        self._answered = ffi.new("uint64_t *")
        self._refused = ffi.new("uint64_t *")
        self.pushed = 0

    def push(self, kind: int, value: float = 0.0, text: str = "",
             args: tuple[int, int, int, int] = (0, 0, 0, 0)) -> int:
        """Publish one input; returns how many this script has pushed (its number + 1)."""
        for i, a in enumerate(args):
            self._args[i] = int(a)
        if lib.live_inbox_push_input(self._box, kind, lib.LIVE_FROM_SCRIPT, float(value),
                                     self._args, text.encode()[:int(lib.LIVE_INPUT_TEXT) - 1]) != 0:
            raise MailboxFull("the engine's mailbox is full: the run does not hold")
        self.pushed += 1
        return self.pushed

    def news(self) -> News:
        word = lib.live_inbox_news(self._box, self._held, self._answered, self._refused)
        return News(int(word), int(self._held[0]), int(self._answered[0]), int(self._refused[0]))

    @property
    def last_refusal(self) -> str:
        return ffi.string(self._box.refused_text).decode(errors="replace")

    def wait_news(self, seen: int, timeout_s: float = SLICE_S) -> bool:
        """Sleep until the engine says something new after ``seen`` (a News.word), at most
        ``timeout_s``. True if it did."""
        return bool(lib.live_inbox_wait(self._box, lib.LIVE_WORD_NEWS, seen & 0xFFFFFFFF,
                                        int(timeout_s * 1e9)))

    def kick(self) -> None:
        """Wake a held engine without an input (it then sees a stop request at once)."""
        lib.live_inbox_kick(self._box)


def wait_until(mailbox: ScriptMailbox, done, look_around, wall_deadline: float,
               on_wall) -> News:
    """Wait until ``done(news)``; between slices ``look_around()`` (raises if the engine or the
    recorder ended) and the wall clock (``on_wall()`` raises once ``wall_deadline``, a
    time.monotonic() value, has passed)."""
    while True:
        news = mailbox.news()
        if done(news):
            return news
        look_around()
        if time.monotonic() > wall_deadline:
            on_wall()
        mailbox.wait_news(news.word)
