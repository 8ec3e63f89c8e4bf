"""CAN logs through python-can's own readers, with every kind of damage found and located.

python-can does all the parsing (``can.io.player.MESSAGE_READERS``: the reader class
``can.LogReader`` picks for the suffix); this module only decides what the reader reads and
watches what it does, so that damage is said with its position and what is intact is read
(docs/replay.md "Damaged captures"):

* **compressed logs** (``.gz``) are decompressed here, in pieces, with ``zlib`` (the gzip
  format); a cut or corrupt compressed stream ends the capture cleanly after the last octets
  that decompressed (``gzip.open`` raises on every later read, and a reader resumed on it would
  never end). Said with the compressed byte offset and the message and line count before it.
* **text logs** (candump ``.log``, ``.asc``, ``.trc``, ``.csv``) are handed to the reader line
  by line through :class:`_Lines`, which counts lines and octets. A line the reader raises on
  is reported (line number, byte offset, the exception) and a new reader of the same class
  resumes after it, with the lines of the file's header served to it again (TRC: version and
  columns; CSV: the header line; ASC: date, base and trigger block), so that no valid line is
  lost and every later line is parsed as the first reader would have. Resuming stops when a
  reader made no progress, and after :data:`MAX_RESUMES` damaged lines.
* **lines a reader passes over** without a message and without raising (ASCReader skips what
  its line pattern does not match; TRCReader logs "Failed to parse message" and goes on) are
  compared with what the format may hold besides frames (blank lines, comments, the header,
  trigger-block lines, other event types): any other is a damaged line, reported by number.
* **a file that does not end in a newline** ends inside its last line: said ("file ends inside
  line N (byte B): truncated") and that line is left out, never parsed half.
* **binary logs**: BLF is read to its end or to the first object python-can cannot read (its
  containers split objects, so no reader picks up after a damaged one); then the header's
  ``file_size`` and ``object_count`` are compared with the octets and messages actually there
  (a cut BLF otherwise replays part of itself without a word). MF4 (python-can's optional
  asammdf) is read up to the first error.
"""
from __future__ import annotations

import logging
import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

MAX_RESUMES = 1000            #: damaged lines after which a text log is read no further
MAX_BAD_IN_A_ROW = 100        #: unreadable lines in a row (no message between) that end it
_GZIP_PIECE = 4096            #: compressed octets decompressed at a time (what a corrupt piece
                              #: can take with it)
_READ_BLOCK = 1 << 16


class _Source:
    """The capture's octets as a python-can reader reads them (``read``, ``readline``): the file,
    or its gzip stream decompressed here. ``pos``: octets delivered (uncompressed); ``problem``:
    why the compressed stream ended early, if it did."""

    def __init__(self, path: Path, compressed: bool):
        self.f = open(path, "rb")
        self.compressed = compressed
        self.d = zlib.decompressobj(wbits=31) if compressed else None
        self.buf = b""               # octets read ahead; buf[off:] not yet delivered
        self.off = 0
        self.pos = 0
        self.eof = False
        self.problem: str | None = None
        self.members_done = 0
        self.fed = False             # octets given to the current gzip member, its end not seen

    # -- filling --------------------------------------------------------------------------------
    def _fill(self) -> bool:
        if self.eof:
            return False
        if not self.compressed:
            data = self.f.read(_READ_BLOCK)
            if not data:
                self.eof = True
                return False
            self._append(data)
            return True
        data = self.f.read(_GZIP_PIECE)
        if not data:
            self.eof = True
            if self.fed:
                self.problem = ("truncated compressed stream: it ends before its end-of-stream "
                                "marker")
            elif self.members_done == 0:
                self.problem = "empty compressed file: no gzip stream in it"
            return False
        try:
            out = self.d.decompress(data)
            self.fed = True
            while self.d.eof:          # the end of a gzip member (a file may hold several)
                self.members_done += 1
                rest = self.d.unused_data
                self.d = zlib.decompressobj(wbits=31)
                self.fed = False
                if not rest:
                    break
                out += self.d.decompress(rest)
                self.fed = True
        except zlib.error as exc:
            self.eof = True
            self.problem = f"corrupt compressed stream (zlib: {exc})"
            return False
        self._append(out)
        return True

    def _append(self, data: bytes) -> None:
        self.buf = self.buf[self.off:] + data
        self.off = 0

    @staticmethod
    def check(path: Path) -> str | None:
        """Why the gzip stream of ``path`` is corrupt (zlib's error, or its CRC), else None: a
        pass over the whole stream before the lines are read, because after a corrupt octet a
        deflate stream decodes to garbage that can look like frames, and zlib notices it only
        later (often at the CRC at the very end)."""
        src = _Source(path, True)
        try:
            while src._fill():
                src.buf, src.off = b"", 0
            if src.problem is not None and src.problem.startswith("corrupt"):
                return f"{src.problem}, found at compressed byte {src.compressed_pos}"
            return None
        finally:
            src.really_close()

    @property
    def compressed_pos(self) -> int:
        return self.f.tell()

    # -- what python-can calls ------------------------------------------------------------------
    def read(self, n: int = -1) -> bytes:
        if n is None or n < 0:
            while self._fill():
                pass
            n = len(self.buf) - self.off
        while len(self.buf) - self.off < n and self._fill():
            pass
        out = self.buf[self.off:self.off + n]
        self.off += len(out)
        self.pos += len(out)
        return out

    def readline(self) -> bytes:
        start = self.off
        while True:
            i = self.buf.find(b"\n", start)
            if i >= 0:
                return self.read(i + 1 - self.off)
            start = len(self.buf) - self.off       # where the search goes on after a fill
            if not self._fill():
                return self.read(len(self.buf) - self.off)
            start = self.off + start

    def close(self) -> None:
        pass          # python-can's readers close their file when done; the owner closes it

    def really_close(self) -> None:
        self.f.close()

    @property
    def closed(self) -> bool:
        return self.f.closed


class _Lines:
    """The text a python-can reader iterates over: the capture's lines, counted. Keeps the lines
    handed out since the last :meth:`mark` (to see what the reader passed over), serves the
    header lines again to a resumed reader, and refuses a last line without its newline."""

    def __init__(self, src: _Source):
        self.src = src
        self.line_no = 0
        self.seen: list[tuple[int, int, str]] = []     # (line, byte offset, text) since mark
        self.replay: list[str] = []
        self.unterminated: tuple[int, int, bytes] | None = None

    def __iter__(self) -> "_Lines":
        return self

    def __next__(self) -> str:
        line = self.readline()
        if not line:
            raise StopIteration
        return line

    def readline(self, size: int = -1) -> str:
        if self.replay:
            return self.replay.pop(0)
        if self.unterminated is not None:
            return ""
        start = self.src.pos
        raw = self.src.readline()
        if not raw:
            return ""
        self.line_no += 1
        if not raw.endswith(b"\n"):
            self.unterminated = (self.line_no, start, raw)
            return ""
        text = raw.decode("utf-8", errors="replace")
        if text.endswith("\r\n"):
            text = text[:-2] + "\n"
        self.seen.append((self.line_no, start, text))
        return text

    def mark(self) -> list[tuple[int, int, str]]:
        out, self.seen = self.seen, []
        return out

    def close(self) -> None:
        pass

    @property
    def closed(self) -> bool:
        return False


# -- what a format may hold besides frames ----------------------------------------------------------

def _asc_patterns():
    from can.io.asc import ASC_TRIGGER_REGEX

    return ASC_TRIGGER_REGEX, [
        re.compile(r"//"), re.compile(r"date\s", re.I), re.compile(r"base\s+(hex|dec)", re.I),
        re.compile(r"(no\s+)?internal\s+events\s+logged", re.I),
        re.compile(r"end\s+triggerblock", re.I),
        re.compile(r"\d+\.\d+\s+start of measurement", re.I)]


#: an ASC event that is not a CAN frame: a time, then a word (Statistic:, J1939TP, CAN 1 Status:,
#: SV: ...) where a frame has its channel number (python-can passes these over on purpose)
_ASC_OTHER_EVENT = re.compile(r"\d+\.\d+\s+[A-Za-z][A-Za-z0-9_]+")


@dataclass
class _Watch:
    """Lines a reader passed over: benign ones ignored, other events counted, the rest damage."""

    fmt: str
    damaged: list[tuple[int, int, str, str]] = field(default_factory=list)  # line, byte, text, why
    other_events: int = 0
    trc_said: dict[int, str] = field(default_factory=dict)    # line -> python-can's log message

    def __post_init__(self):
        self._asc = _asc_patterns() if self.fmt == ".asc" else None

    def passed_over(self, line_no: int, byte: int, text: str) -> None:
        s = text.strip()
        if not s:
            return
        if self.fmt == ".csv":
            if line_no == 1:
                return
            why = "python-can's CSVReader read no message from it"
        elif self.fmt == ".trc":
            if s.startswith(";"):
                return
            said = self.trc_said.get(line_no, "")
            if "Unsupported type" in said or "bus info" in said:
                self.other_events += 1
                return
            why = (f"python-can's TRCReader passed over it ({said})" if said else
                   "python-can's TRCReader read no message from it")
        elif self.fmt == ".asc":
            trig, benign = self._asc
            if trig.match(s) or any(p.match(s) for p in benign):
                return
            if _ASC_OTHER_EVENT.match(s):
                self.other_events += 1
                return
            why = "not a frame python-can's ASCReader reads (it passes over such lines)"
        else:
            why = "python-can's reader read no message from it"
        self.damaged.append((line_no, byte, s[:60], why))


class _TrcLog(logging.Handler):
    """What TRCReader says about the line it is on (it logs instead of raising)."""

    def __init__(self, lines: _Lines, watch: _Watch):
        super().__init__(logging.INFO)
        self.lines, self.watch = lines, watch

    def emit(self, record: logging.LogRecord) -> None:
        self.watch.trc_said[self.lines.line_no] = record.getMessage()[:80]


@dataclass
class LogResult:
    messages: int = 0
    problems: list[str] = field(default_factory=list)
    damaged: list[tuple[str, str]] = field(default_factory=list)   # where, what (anomalies)
    notes: list[str] = field(default_factory=list)


def _suffix(path: Path) -> tuple[str, bool]:
    name = path.name.lower()
    gz = name.endswith(".gz")
    base = name[:-3] if gz else name
    return Path(base).suffix, gz


def read_log(path: Path, on_message: Callable[[object, str], None]) -> LogResult:
    """Every readable message of a CAN log, in file order, to ``on_message(msg, where)``
    (``where``: "line N" or "message N"). Raises ValueError if python-can cannot read the file
    at all (the message says why)."""
    import can
    from can.io.generic import BinaryIOMessageReader, TextIOMessageReader
    from can.io.player import MESSAGE_READERS

    suffix, gz = _suffix(path)
    reader_cls = MESSAGE_READERS.get(suffix)
    res = LogResult()
    if reader_cls is None or not (issubclass(reader_cls, TextIOMessageReader)
                                  or reader_cls.__name__ == "BLFReader"):
        _read_other(path, can, res, on_message)       # MF4, plugins: as can.LogReader opens them
        return res
    src = _Source(path, gz)
    try:
        if issubclass(reader_cls, TextIOMessageReader):
            _read_text(path, reader_cls, suffix, src, res, on_message)
        else:
            assert issubclass(reader_cls, BinaryIOMessageReader)
            _read_blf(path, reader_cls, src, res, on_message)
    finally:
        src.really_close()
    return res


def _stream_end(path: Path, src: _Source, res: LogResult, after: str) -> None:
    if src.problem is not None:
        res.problems.append(f"{path}: {src.problem} at compressed byte {src.compressed_pos} "
                            f"(after {after}, {src.pos} octets decompressed); the capture ends "
                            f"there, what came before is replayed")
        res.damaged.append((f"compressed byte {src.compressed_pos}", src.problem))


def _read_text(path: Path, reader_cls, fmt: str, src: _Source, res: LogResult,
               on_message) -> None:
    corrupt = _Source.check(path) if src.compressed else None
    lines = _Lines(src)
    watch = _Watch(fmt)
    header: list[str] | None = None
    resumes = 0
    in_a_row = 0
    trc_logger = logging.getLogger("can.io.trc")
    handler = _TrcLog(lines, watch)
    saved = (trc_logger.level, trc_logger.propagate)
    if fmt == ".trc":
        trc_logger.addHandler(handler)
        trc_logger.setLevel(logging.INFO)
        trc_logger.propagate = False
    try:
        while True:
            line_before = lines.line_no
            it = iter(reader_cls(lines))
            while True:
                try:
                    msg = next(it)
                except StopIteration:
                    msg = None
                    exc = None
                except Exception as e:  # noqa: BLE001 - python-can raises ValueError, IndexError..
                    msg = None
                    exc = e
                seen = lines.mark()
                if msg is not None:
                    if header is None:
                        header = [t for _n, _b, t in seen[:-1]]
                    for n, b, t in seen[:-1]:
                        watch.passed_over(n, b, t)
                    in_a_row = 0
                    res.messages += 1
                    on_message(msg, f"line {seen[-1][0] if seen else lines.line_no}")
                    continue
                if exc is None:                  # the end of the file
                    for n, b, t in seen:
                        watch.passed_over(n, b, t)
                    break
                if header is None:
                    header = [t for _n, _b, t in seen[:-1]]
                for n, b, t in seen[:-1]:
                    watch.passed_over(n, b, t)
                ln, byte, text = seen[-1] if seen else (lines.line_no, src.pos, "")
                what = f"{type(exc).__name__}: {exc}"
                res.damaged.append((f"line {ln} (byte {byte})",
                                    f"unreadable to python-can's {reader_cls.__name__} ({what}): "
                                    f"{text.strip()[:60]!r}; left out"))
                break
            if exc is None:
                break
            if corrupt is not None:
                res.problems.append(f"{path}: {corrupt}: the text it decodes to is garbage from "
                                    f"somewhere before there, so the capture is read up to its "
                                    f"first unreadable line, line {ln}")
                break
            if lines.line_no == line_before or not seen:
                res.problems.append(f"{path}: line {ln} (byte {byte}): python-can's "
                                    f"{reader_cls.__name__} cannot go on ({what}); the capture "
                                    f"is read up to there")
                break
            in_a_row += 1
            if resumes >= MAX_RESUMES or in_a_row >= MAX_BAD_IN_A_ROW:
                why = (f"more than {MAX_RESUMES} unreadable lines" if resumes >= MAX_RESUMES
                       else f"{in_a_row} unreadable lines in a row")
                res.problems.append(f"{path}: {why} (python-can's {reader_cls.__name__}); the "
                                    f"capture is read up to line {ln}")
                break
            resumes += 1                         # a new reader after the bad line, header again
            lines.replay = list(header or [])
    finally:
        if fmt == ".trc":
            trc_logger.removeHandler(handler)
            trc_logger.setLevel(saved[0])
            trc_logger.propagate = saved[1]
    for n, b, t, why in watch.damaged:
        res.damaged.append((f"line {n} (byte {b})", f"{why}: {t!r}; left out"))
    bad = sorted([int(w.split()[1]) for w, _ in res.damaged if w.startswith("line ")])
    if bad:
        shown = ", ".join(str(x) for x in bad[:10]) + (", ..." if len(bad) > 10 else "")
        res.problems.append(f"{path}: {len(bad)} damaged line(s) left out (line{'s' if len(bad) > 1 else ''} "
                            f"{shown})")
    if watch.other_events:
        res.notes.append(f"{watch.other_events} line(s) of other event types (not CAN frames) "
                         f"passed over, as python-can's {reader_cls.__name__} does")
    if corrupt is None:
        _stream_end(path, src, res, f"message {res.messages}, line {lines.line_no}")
    elif not any(corrupt in p for p in res.problems):
        res.problems.append(f"{path}: {corrupt}; every line decoded was readable (the damage is "
                            f"in the stream's trailer, or changed values that still parse: the "
                            f"capture's values cannot be trusted)")
        res.damaged.append((f"compressed byte {src.compressed_pos}", corrupt))
    if lines.unterminated is not None:
        n, b, raw = lines.unterminated
        res.problems.append(f"{path}: file ends inside line {n} (byte {b}"
                            f"{' of the decompressed text' if src.compressed else ''}): truncated; "
                            f"that line ({len(raw)} octets, no newline) is left out")
        res.damaged.append((f"line {n} (byte {b})", "the file ends inside this line; left out"))


def _read_blf(path: Path, reader_cls, src: _Source, res: LogResult, on_message) -> None:
    """BLF: python-can's BLFReader over the stream, up to the first object it cannot read (its
    containers split objects, so a reader cannot pick up after a damaged one); then the
    header's size and object count are compared with what was there."""
    try:
        reader = reader_cls(src)
    except Exception as exc:  # noqa: BLE001 - struct.error, BLFParseError on a bad header
        _stream_end(path, src, res, "the file header")
        raise ValueError(f"python-can's {reader_cls.__name__} cannot read the header: "
                         f"{type(exc).__name__}: {exc}") from None
    want_size = int(getattr(reader, "file_size", 0) or 0)
    want_objects = int(getattr(reader, "object_count", 0) or 0)
    try:
        for msg in reader:
            res.messages += 1
            on_message(msg, f"message {res.messages}")
    except Exception as exc:  # noqa: BLE001 - BLFParseError, zlib.error, struct.error
        what = f"{type(exc).__name__}: {exc}"
        res.problems.append(f"{path}: byte {src.pos}{' (decompressed)' if src.compressed else ''}"
                            f": python-can's {reader_cls.__name__} cannot read on after message "
                            f"{res.messages} ({what}); a BLF is read up to its first unreadable "
                            f"object (the header counts {want_objects})")
        res.damaged.append((f"byte {src.pos}", f"an object python-can's {reader_cls.__name__} "
                                               f"cannot read ({what})"))
        _stream_end(path, src, res, f"message {res.messages}")
        return
    _stream_end(path, src, res, f"message {res.messages}")
    if want_size == 0:
        res.notes.append("the BLF header gives no file size (the logger did not close the file): "
                         "a cut cannot be told from its header")
        return
    if src.pos < want_size:
        res.problems.append(f"{path}: truncated: the BLF header says {want_size} octets and "
                            f"{want_objects} objects, the file has {src.pos} octets and "
                            f"{res.messages} messages were read")
        res.damaged.append((f"byte {src.pos}", "the BLF file ends before the size its header "
                                               "gives"))
    elif res.messages < want_objects:
        res.problems.append(f"{path}: the BLF header counts {want_objects} objects, "
                            f"{res.messages} messages were read (objects other than CAN frames, "
                            f"or objects python-can passed over)")


def _read_other(path: Path, can, res: LogResult, on_message) -> None:
    try:
        reader = can.LogReader(str(path))
    except NotImplementedError as exc:    # e.g. .mf4 without asammdf
        raise ValueError(f"python-can cannot read this format here: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - python-can raises many kinds on a bad header
        raise ValueError(f"python-can cannot open it: {type(exc).__name__}: {exc}") from None
    try:
        for msg in reader:
            res.messages += 1
            on_message(msg, f"message {res.messages}")
    except Exception as exc:  # noqa: BLE001
        res.problems.append(f"{path}: python-can's {type(reader).__name__} cannot read on after "
                            f"message {res.messages} ({type(exc).__name__}: {exc}); the capture "
                            f"is read up to there")
        res.damaged.append((f"message {res.messages + 1}", f"unreadable ({type(exc).__name__})"))
    finally:
        try:
            reader.stop()
        except Exception:  # noqa: BLE001
            pass


__all__ = ["LogResult", "MAX_RESUMES", "read_log"]
