"""The firmware on an emulated microcontroller: ``--link pil-qemu``.

QEMU's ``netduinoplus2`` machine (an STM32F405, Cortex-M4F with its single-precision FPU) runs
the bare-metal port ``firmware_stub/port/cortex_m`` (``hil_fw_cm4.elf``): the same portable C as
the host stub, cross-compiled, no OS, no heap, its USART1 interrupt-driven. The bench owns the
emulator as it owns the stub (``stub.py``):

* it finds the ELF (``$HIL_QEMU_ELF``, else ``build/cortex_m/hil_fw_cm4.elf``, brought up to date
  with ``cmake --build`` when the cross compiler is installed);
* starts ``qemu-system-arm -machine netduinoplus2 -nographic -S`` with USART1 on a character
  device the bench opens (a Unix socket in a private temporary folder, QEMU listening), QMP on
  the process's stdin/stdout and ``-icount shift=0``;
* connects, waits until QMP's ``query-chardev`` shows QEMU has taken the connection, and only
  then lets the CPU run (``cont``): nothing either side sends is lost. (Not ``-serial pty``:
  QEMU's pty backend looks for a reader once a second and until then drops what the host writes;
  measured here, 8 HELLOs of 8 sent 0.35 s after opening the pty were never read by the target.
  A pty is fine by hand when the first frame comes a second later: docs/real-drive.md.)
* at the end reads the target's own measurements (``target_stats.h``, at 0x20000000) through
  QMP, closes the link, ``quit``\\ s QEMU, and kills and reaps it if it lingers; its stderr is
  kept for the error messages, and a target that took a HardFault says where.

Emulated time: with ``-icount shift=0`` the virtual clock advances 1 ns per guest instruction
(and with the host's clock while the CPU sleeps in WFI), so the SysTick ticks the firmware
counts around its control ISR are instructions: ``ticks * 1e9 / 168e6``. QEMU runs the code as
fast as it can; in lockstep only the order of frames matters, not the emulator's speed.
"""
from __future__ import annotations

import collections
import fcntl
import json
import os
import queue
import shutil
import socket
import struct
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass, fields
from pathlib import Path

from .base import LinkError, reap
from .serial_link import FdTransport, SerialLink

REPO_ROOT = Path(__file__).resolve().parents[3]
PORT_DIR = REPO_ROOT / "firmware_stub" / "port" / "cortex_m"
BUILD_DIR = REPO_ROOT / "build" / "cortex_m"
ELF_NAME = "hil_fw_cm4.elf"
QEMU = "qemu-system-arm"
MACHINE = "netduinoplus2"
ICOUNT_SHIFT = 0                 #: 2**shift ns of virtual time per guest instruction
CORE_CLOCK_HZ = 168_000_000      #: netduinoplus2's fixed SYSCLK (SysTick counts it)
STATS_ADDR = 0x20000000          #: target_stats.h: the start of SRAM
CHARDEV = "usart1"               #: QEMU's character device behind the machine's USART1
QMP_TIMEOUT_S = 5.0
START_TIMEOUT_S = 10.0
INSTALL_HINT = ("apt-get install qemu-system-arm gcc-arm-none-eabi libnewlib-arm-none-eabi, "
                "then `make firmware-cm4`")

COUNTER_KINDS = {0: "none", 1: "DWT cycles", 2: "SysTick ticks"}
TARGET_STATES = {0: "booting", 1: "running", 2: "HardFault"}
CLOCK_FLAGS = {1: "HSE ready", 2: "PLL locked", 4: "no RCC (emulated, fixed 168 MHz)",
               8: "HSE timeout", 16: "PLL timeout"}


@dataclass
class TargetStats:
    """``hil_target_stats_t`` (firmware_stub/port/cortex_m/target_stats.h), field for field."""

    magic: int
    version: int
    state: int
    clock_hz: int
    clock_flags: int
    usart_baud: int
    usart_brr: int
    stack_size_bytes: int
    stack_used_bytes: int
    counter_kind: int
    isr_count: int
    isr_ticks_min: int
    isr_ticks_max: int
    isr_ticks_sum_lo: int
    isr_ticks_sum_hi: int
    isr_ticks_last: int
    rx_bytes: int
    rx_ring_overflows: int
    usart_overruns: int
    tx_bytes: int
    tx_ring_overflows: int
    frames_ok: int
    crc_errors: int
    cobs_errors: int
    length_errors: int
    deframer_overruns: int
    session_cycles: int
    unknown_ids: int
    heartbeats: int
    fault_cfsr: int
    fault_hfsr: int
    fault_pc: int
    fault_lr: int
    fault_bfar: int
    fault_mmfar: int
    ram_used_bytes: int
    calib_loops: int
    calib_ticks: int
    calib_empty_ticks: int
    restarts: int        # controller restarts (CMD RESTART) the session took
    #: not in the block: QEMU's -icount shift when the ticks are instructions, else None
    icount_shift: int | None = None

    MAGIC = 0x53484948
    VERSION = 2

    @classmethod
    def words(cls) -> int:
        return len(fields(cls)) - 1

    @classmethod
    def from_bytes(cls, data: bytes, icount_shift: int | None = None) -> "TargetStats":
        n = cls.words()
        if len(data) < 4 * n:
            raise ValueError(f"target stats: {len(data)} octets, {4 * n} expected")
        st = cls(*struct.unpack_from(f"<{n}I", data), icount_shift=icount_shift)
        if st.magic != cls.MAGIC:
            raise ValueError(f"target stats: magic 0x{st.magic:08X} at 0x{STATS_ADDR:08X}, "
                             f"0x{cls.MAGIC:08X} expected (not this firmware, or it never booted)")
        if st.version != cls.VERSION:
            raise ValueError(f"target stats: layout version {st.version}, {cls.VERSION} expected "
                             f"(rebuild the firmware and the bench together)")
        return st

    @property
    def isr_ticks_sum(self) -> int:
        return self.isr_ticks_sum_lo | (self.isr_ticks_sum_hi << 32)

    def ticks_to_instructions(self, ticks: float) -> float | None:
        """SysTick ticks under ``-icount shift=N`` -> guest instructions (None without icount:
        then the ticks are the host's wall clock)."""
        if self.counter_kind != 2 or self.clock_hz <= 0 or self.icount_shift is None:
            return None
        return ticks * 1e9 / self.clock_hz / (1 << self.icount_shift)

    def isr_instructions(self) -> dict[str, float] | None:
        """Instructions per control ISR (mean, min, max) over the run; None before any ran."""
        if self.isr_count == 0:
            return None
        conv = self.ticks_to_instructions
        mean = conv(self.isr_ticks_sum / self.isr_count)
        if mean is None:
            return None
        return {"mean": mean, "min": conv(self.isr_ticks_min), "max": conv(self.isr_ticks_max)}

    def calibration(self) -> tuple[float, int] | None:
        """(instructions the counter measured, instructions executed) for the boot-time loop of
        ``calib_loops`` x (subs; bne): the check that ticks -> instructions is right."""
        measured = self.ticks_to_instructions(self.calib_ticks - self.calib_empty_ticks)
        return None if measured is None else (measured, 2 * self.calib_loops)

    def fault_text(self) -> str | None:
        if self.state != 2:
            return None
        if self.fault_pc == 0 and self.fault_cfsr == 0:
            return f"the target took unhandled exception {self.fault_hfsr} (no handler)"
        return (f"the target took a HardFault at PC 0x{self.fault_pc:08X} (LR 0x{self.fault_lr:08X},"
                f" CFSR 0x{self.fault_cfsr:08X}, HFSR 0x{self.fault_hfsr:08X}, BFAR "
                f"0x{self.fault_bfar:08X}): arm-none-eabi-addr2line -e {ELF_NAME} "
                f"0x{self.fault_pc:08X}")

    def as_metadata(self) -> dict[str, str]:
        """The recording's ``target`` metadata record (str -> str)."""
        out = {f.name: str(getattr(self, f.name)) for f in fields(self) if f.name != "icount_shift"}
        out["counter"] = COUNTER_KINDS.get(self.counter_kind, "?")
        out["state_name"] = TARGET_STATES.get(self.state, "?")
        out["clock"] = ", ".join(t for b, t in CLOCK_FLAGS.items() if self.clock_flags & b)
        ins = self.isr_instructions()
        if ins is not None:
            out.update({f"isr_instructions_{k}": f"{v:.0f}" for k, v in ins.items()})
            out["icount_shift"] = str(self.icount_shift)
            measured, executed = self.calibration()
            out["calibration"] = (f"{measured:.0f} instructions counted for {executed} executed "
                                  f"(boot-time loop)")
        return out


def qemu_path() -> str:
    path = shutil.which(QEMU)
    if path is None:
        raise LinkError(f"{QEMU} not found: --link pil-qemu needs it ({INSTALL_HINT})")
    return path


def firmware_elf(build: bool = True) -> Path:
    """The Cortex-M ELF: ``$HIL_QEMU_ELF`` as given, else ``build/cortex_m/hil_fw_cm4.elf``, which
    ``cmake --build`` brings up to date first when the cross compiler is installed (one build at
    a time: parallel runs wait on a lock)."""
    env = os.environ.get("HIL_QEMU_ELF")
    if env:
        path = Path(env)
        if not path.is_file():
            raise LinkError(f"$HIL_QEMU_ELF names {path}: no such file")
        return path
    elf = BUILD_DIR / ELF_NAME
    if build and shutil.which("arm-none-eabi-gcc") is not None:
        BUILD_DIR.mkdir(parents=True, exist_ok=True)
        with open(BUILD_DIR / ".build.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            cmds = []
            if not (BUILD_DIR / "CMakeCache.txt").exists():
                cmds.append(["cmake", "-S", str(PORT_DIR), "-B", str(BUILD_DIR),
                             f"-DCMAKE_TOOLCHAIN_FILE={PORT_DIR / 'arm-none-eabi.cmake'}"])
            cmds.append(["cmake", "--build", str(BUILD_DIR)])
            for cmd in cmds:
                r = subprocess.run(cmd, capture_output=True, text=True)
                if r.returncode != 0:
                    tail = "\n    ".join((r.stdout + r.stderr).strip().splitlines()[-15:])
                    raise LinkError(f"building the Cortex-M firmware failed ({' '.join(cmd)}):"
                                    f"\n    {tail}")
    if not elf.is_file():
        raise LinkError(f"Cortex-M firmware not found at {elf} ({INSTALL_HINT})")
    return elf


class _Qmp:
    """QMP on the emulator's stdin/stdout: one command at a time, events set aside."""

    def __init__(self, proc: subprocess.Popen):
        self.proc = proc
        self.replies: queue.Queue = queue.Queue()
        self.events: list[dict] = []
        self.other_lines: collections.deque[str] = collections.deque(maxlen=20)
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True, name="qemu-qmp")
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            try:
                msg = json.loads(line)
            except ValueError:
                self.other_lines.append(line.rstrip())   # "char device redirected to ..."
                continue
            if "event" in msg:
                self.events.append(msg)
            else:
                self.replies.put(msg)
        self.replies.put(None)   # end of stream: QEMU has gone

    def greeting(self, timeout_s: float) -> dict:
        return self._get(timeout_s, "the QMP greeting")

    def _get(self, timeout_s: float, what: str) -> dict:
        try:
            msg = self.replies.get(timeout=timeout_s)
        except queue.Empty:
            raise LinkError(f"QEMU did not answer {what} within {timeout_s:g} s") from None
        if msg is None:
            self.replies.put(None)
            raise LinkError(f"QEMU closed its QMP channel (waiting for {what})")
        return msg

    def command(self, name: str, timeout_s: float = QMP_TIMEOUT_S, **arguments) -> object:
        with self._lock:
            req = {"execute": name}
            if arguments:
                req["arguments"] = arguments
            try:
                self.proc.stdin.write(json.dumps(req) + "\n")
                self.proc.stdin.flush()
            except (BrokenPipeError, OSError, ValueError):
                raise LinkError(f"QEMU is gone (QMP {name})") from None
            msg = self._get(timeout_s, f"QMP {name}")
        if "error" in msg:
            raise LinkError(f"QMP {name}: {msg['error'].get('desc', msg['error'])}")
        return msg.get("return")

    def read_memory(self, addr: int, n_words: int) -> bytes:
        """Guest physical memory, through the monitor's ``xp`` (no file involved)."""
        text = self.command("human-monitor-command", **{"command-line": f"xp /{n_words}wx {addr:#x}"})
        words: list[int] = []
        for line in str(text).splitlines():
            _, _, values = line.partition(":")
            words += [int(v, 16) for v in values.split()]
        if len(words) < n_words:
            raise LinkError(f"QEMU read {len(words)} of {n_words} words at {addr:#x}: {text!r}")
        return struct.pack(f"<{n_words}I", *words[:n_words])


class QemuProcess:
    """A running QEMU with the firmware, and ``link``, the bench's end of its USART1."""

    def __init__(self, elf: Path | None = None, extra_args: tuple[str, ...] = (),
                 icount: bool = True):
        """``icount``: count instructions (``-icount shift=0``; about twice QEMU's CPU time per
        cycle); without it the target's ISR figures are host wall-clock ticks and are dropped."""
        self.elf = Path(elf) if elf is not None else firmware_elf()
        self.icount = icount
        self.executable = qemu_path()
        self.controller = (f"{self.elf.name} on {QEMU} -machine {MACHINE} (STM32F405, "
                           f"Cortex-M4F)" + (f", -icount shift={ICOUNT_SHIFT}" if icount else ""))
        self.stderr_tail: collections.deque[str] = collections.deque(maxlen=20)
        self.target_stats: TargetStats | None = None
        self._stats_checked = 0.0
        self._faulted: str | None = None
        self._sock: socket.socket | None = None
        self._dir = tempfile.mkdtemp(prefix="hil-qemu-")
        self.socket_path = os.path.join(self._dir, "usart1.sock")
        args = [self.executable, "-machine", MACHINE, "-nographic", "-kernel", str(self.elf),
                "-chardev", f"socket,id={CHARDEV},path={self.socket_path},server=on,wait=off",
                "-serial", f"chardev:{CHARDEV}", "-monitor", "none", "-qmp", "stdio",
                *(["-icount", f"shift={ICOUNT_SHIFT}"] if icount else []), "-S", *extra_args]
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True, close_fds=True,
                                     start_new_session=True)   # Ctrl-C reaches the bench only
        self._stderr_reader = threading.Thread(target=self._drain_stderr, daemon=True)
        self._stderr_reader.start()
        self.qmp = _Qmp(self.proc)
        try:
            self._start()
        except LinkError as exc:
            self._abandon()
            raise LinkError(f"{exc}; {self.death_message()}") from None

    def _start(self) -> None:
        self.qmp.greeting(START_TIMEOUT_S)
        self.qmp.command("qmp_capabilities")
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            self._sock.connect(self.socket_path)
        except OSError as exc:
            raise LinkError(f"cannot connect to QEMU's USART1 at {self.socket_path}: "
                            f"{exc.strerror}") from None
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:   # QEMU accepts in its main loop: until then it would drop the guest's octets
            chardevs = self.qmp.command("query-chardev") or []
            name = next((c["filename"] for c in chardevs if c.get("label") == CHARDEV), "")
            if name and not name.startswith("disconnected:"):
                break
            if time.monotonic() > deadline:
                raise LinkError(f"QEMU did not take the USART1 connection within "
                                f"{START_TIMEOUT_S:g} s ({name!r})")
            time.sleep(0.005)
        self._sock.setblocking(False)
        self.link = SerialLink(FdTransport(self._sock.fileno(),
                                           f"USART1 of {self.elf.name} in {QEMU} (pid "
                                           f"{self.proc.pid}) on {self.socket_path}"))
        self.qmp.command("cont")   # the CPU runs only now: the bench is listening

    def _drain_stderr(self) -> None:
        for line in self.proc.stderr:
            self.stderr_tail.append(line.rstrip())

    # -- what the target says about itself --------------------------------------------------
    def read_stats(self) -> TargetStats:
        try:
            data = self.qmp.read_memory(STATS_ADDR, TargetStats.words())
            return TargetStats.from_bytes(data, ICOUNT_SHIFT if self.icount else None)
        except ValueError as exc:
            raise LinkError(str(exc)) from None

    def _target_fault(self) -> str | None:
        """The target's HardFault, if it took one (read at most every 0.2 s)."""
        if self._faulted is not None or self.proc.poll() is not None:
            return self._faulted
        now = time.monotonic()
        if now - self._stats_checked >= 0.2:
            self._stats_checked = now
            try:
                self._faulted = self.read_stats().fault_text()
            except LinkError:
                pass
        return self._faulted

    # -- the stub's interface (runner, conformance) ------------------------------------------
    def alive(self) -> bool:
        """QEMU runs and the firmware has not stopped in a fault handler."""
        return self.proc.poll() is None and self._target_fault() is None

    def death_message(self) -> str:
        code = self.proc.poll()
        self._stderr_reader.join(timeout=0.5)
        tail = "\n    ".join(list(self.stderr_tail) + list(self.qmp.other_lines)) or "(no output)"
        if code is None:
            fault = self._target_fault()
            if fault:
                return f"{fault}; {QEMU} (pid {self.proc.pid}) still runs"
            return f"the firmware in {QEMU} (pid {self.proc.pid}) stopped answering; stderr:\n    {tail}"
        how = f"killed by signal {-code}" if code < 0 else f"exited with code {code}"
        return f"{QEMU} {how}; its last stderr lines:\n    {tail}"

    def stop(self, timeout_s: float = 2.0) -> int | None:
        """Read the target's statistics, close the link, quit QEMU (kill it if it lingers)."""
        if self.proc.poll() is None:
            try:
                self.target_stats = self.read_stats()
            except LinkError as exc:
                self.stderr_tail.append(f"bench: target statistics not read: {exc}")
        self._close_socket()
        return self._end(timeout_s)

    def _close_socket(self) -> None:
        if self._sock is not None:
            if hasattr(self, "link"):
                self.link.close()      # closes the descriptor
                self._sock.detach()
            else:
                self._sock.close()
            self._sock = None

    def _end(self, timeout_s: float) -> int | None:
        if self.proc.poll() is None:
            try:
                self.qmp.command("quit", timeout_s=timeout_s)
            except LinkError:
                pass
        try:
            return reap(self.proc, timeout_s)
        finally:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
            self._stderr_reader.join(timeout=1.0)
            shutil.rmtree(self._dir, ignore_errors=True)

    def _abandon(self) -> None:
        self._close_socket()
        self.proc.terminate()
        self._end(2.0)
