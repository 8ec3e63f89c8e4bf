"""The firmware on an emulated microcontroller: ``--link pil-qemu``.

QEMU's ``netduinoplus2`` machine (an STM32F405, Cortex-M4F with its single-precision FPU) runs
the bare-metal port ``firmware_stub/port/cortex_m`` (``hil_fw_cm4.elf``): the same portable C as
the host stub, cross-compiled, no OS, no heap, its USART1 interrupt-driven. The bench owns the
emulator as it owns the stub (``stub.py``):

* it finds the ELF (``$HIL_QEMU_ELF``, else ``build/cortex_m/hil_fw_cm4.elf``, brought up to date
  with ``cmake --build`` when the cross compiler is installed);
* starts ``qemu-system-arm -machine netduinoplus2 -nographic -S`` with USART1 on a character
  device the bench opens (a Unix socket in a private temporary folder, QEMU listening, behind
  QEMU's multiplexer: ``mux=on``, below), the human monitor (HMP, ``qemu_monitor.py``) on the
  process's stdin/stdout and ``-icount shift=0``;
* connects, waits until ``info chardev`` shows QEMU has taken the connection, and only then lets
  the CPU run (``cont``): nothing either side sends is lost. (Not ``-serial pty``: QEMU's pty
  backend looks for a reader once a second and until then drops what the host writes; measured
  here, 8 HELLOs of 8 sent 0.35 s after opening the pty were never read by the target. A pty is
  fine by hand when the first frame comes a second later: docs/real-drive.md.)
* at the end reads the target's own measurements (``target_stats.h``, at 0x20000000) with the
  monitor's ``xp``, closes the link, ``quit``\\ s QEMU, and kills and reaps it if it lingers; its
  stderr is kept for the error messages, and a target that took a HardFault says where.

Speed (docs/performance.md, "The Cortex-M target"): QEMU's USART model takes one octet at a
time, and only after the firmware read the last one from DR. Straight from the socket, each
received octet waited for a turn of QEMU's main loop (a thread switch each way), and every read
of the USART's SR or DR woke that loop. With ``mux=on`` the multiplexer reads ahead up to 32
octets and hands the next one to the USART as soon as DR is read, in the CPU's thread, and the
firmware reads every octet that is there in one interrupt (usart.c); with HMP no monitor thread
wakes per register read (qemu_monitor.py).

Emulated time: with ``-icount shift=0`` the virtual clock advances 1 ns per guest instruction
(and with the host's clock while the CPU sleeps in WFI), so the SysTick ticks the firmware
counts around its control ISR are instructions: ``ticks * 1e9 / 168e6``. QEMU runs the code as
fast as it can; in lockstep only the order of frames matters, not the emulator's speed.
"""
from __future__ import annotations

import collections
import fcntl
import hashlib
import os
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
from .qemu_monitor import HumanMonitor
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
#: ``mux=on`` puts QEMU's multiplexer between the socket and USART1 (``usart1`` the multiplexer,
#: ``usart1-base`` the socket): it buffers up to 32 received octets and hands the next one to the
#: USART as soon as the firmware has read the last, in the CPU's own thread. Without it each
#: octet waits for a turn of QEMU's main loop after the firmware read the previous one.
SOCKET_CHARDEV = f"{CHARDEV}-base"
#: the multiplexer's escape character (default Ctrl-A, then ``x`` quits QEMU, ``c`` switches the
#: input to the monitor): set beyond a byte, so that no octet of the binary link is taken for one
NO_ESCAPE_CHAR = 256
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
    flash_used_bytes: int   # the image in flash (vectors, code, constants, .data's copy)
    flash_size_bytes: int
    ram_size_bytes: int
    #: not in the block: QEMU's -icount shift when the ticks are instructions, else None
    icount_shift: int | None = None
    #: not in the block: the image that ran (its file name and SHA-256)
    elf: str = ""
    elf_sha256: str = ""
    #: not in the block: CPU seconds the emulator process used (user + system), None if unread
    emulator_cpu_s: float | None = None

    MAGIC = 0x53484948
    VERSION = 3
    #: the fields after the block's words
    NOT_IN_BLOCK = ("icount_shift", "elf", "elf_sha256", "emulator_cpu_s")

    @classmethod
    def words(cls) -> int:
        return len(fields(cls)) - len(cls.NOT_IN_BLOCK)

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
        out = {f.name: str(getattr(self, f.name)) for f in fields(self)
               if f.name not in self.NOT_IN_BLOCK}
        if self.elf:
            out["elf"], out["elf_sha256"] = self.elf, self.elf_sha256
        if self.emulator_cpu_s is not None:
            out["emulator_cpu_s"] = f"{self.emulator_cpu_s:.2f}"
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


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _grouped(n: int | float) -> str:
    return f"{n:,.0f}".replace(",", " ")


def target_summary(meta: dict[str, str]) -> list[str]:
    """The target's figures of a run as text lines, from the recording's ``target`` metadata
    (``bench run --link pil-qemu`` prints them at the end, ``bench check`` too)."""
    try:
        return _summary_lines(meta)
    except (ValueError, TypeError) as exc:
        return [f"target: its figures in the recording's metadata are not numbers ({exc})"]


def _summary_lines(meta: dict[str, str]) -> list[str]:
    def num(key: str) -> int:
        return int(meta.get(key, "0") or 0)

    lines = [f"target: {meta.get('elf') or ELF_NAME} on {QEMU} {MACHINE} (STM32F405, Cortex-M4F, "
             f"{num('clock_hz') / 1e6:g} MHz), {meta.get('state_name', '?')}"]
    if meta.get("isr_instructions_mean"):
        lines += [f"  control ISR: {_grouped(float(meta['isr_instructions_mean']))} instructions "
                  f"mean, {_grouped(float(meta['isr_instructions_max']))} max, "
                  f"{_grouped(float(meta['isr_instructions_min']))} min over "
                  f"{_grouped(num('isr_count'))} ISRs",
                  f"    (guest instructions, counted with -icount shift="
                  f"{meta.get('icount_shift', '?')}; not core cycles: docs/ports.md)"]
    elif num("isr_count"):
        lines.append(f"  control ISR: {_grouped(num('isr_count'))} ISRs, no instruction count "
                     f"(the emulator ran without -icount)")
    flash = (f"flash {_grouped(num('flash_used_bytes'))} B of {_grouped(num('flash_size_bytes'))} B"
             if num("flash_size_bytes") else "flash not reported (a firmware before stats layout 3)")
    lines.append(f"  stack: {_grouped(num('stack_used_bytes'))} B used of "
                 f"{_grouped(num('stack_size_bytes'))} B; {flash}; RAM "
                 f"{_grouped(num('ram_used_bytes'))} B static + {_grouped(num('stack_size_bytes'))}"
                 f" B stack" + (f" of {_grouped(num('ram_size_bytes'))} B" if num("ram_size_bytes")
                                else ""))
    errors = sum(num(k) for k in ("crc_errors", "cobs_errors", "length_errors", "usart_overruns",
                                  "rx_ring_overflows", "tx_ring_overflows", "deframer_overruns"))
    cpu = (f"; the emulator used {float(meta['emulator_cpu_s']):.1f} s of CPU"
           if meta.get("emulator_cpu_s") else "")
    lines.append(f"  link: {_grouped(num('rx_bytes'))} octets in, {_grouped(num('tx_bytes'))} out, "
                 f"{errors} errors seen by the target{cpu}")
    return lines


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
    if not PORT_DIR.is_dir() and not elf.is_file():
        # an installed package carries no Cortex-M sources to build (a wheel's hil_bench has
        # neither firmware_stub/port nor a CMake project for it)
        raise LinkError(f"--link pil-qemu needs a checkout of hil-bench (firmware_stub/port/"
                        f"cortex_m, built with `make firmware-cm4`), or the firmware ELF given: "
                        f"pil-qemu:<path to {ELF_NAME}> or $HIL_QEMU_ELF")
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


class QemuProcess:
    """A running QEMU with the firmware, and ``link``, the bench's end of its USART1."""

    def __init__(self, elf: Path | None = None, extra_args: tuple[str, ...] = (),
                 icount: bool = True):
        """``icount``: count instructions (``-icount shift=0``; about twice QEMU's CPU time per
        cycle); without it the target's ISR figures are host wall-clock ticks and are dropped."""
        self.elf = Path(elf) if elf is not None else firmware_elf()
        if not self.elf.is_file():
            raise LinkError(f"pil-qemu: the firmware ELF {self.elf} does not exist")
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
                "-chardev", f"socket,id={CHARDEV},path={self.socket_path},server=on,wait=off,"
                            f"mux=on", "-echr", str(NO_ESCAPE_CHAR),
                "-serial", f"chardev:{CHARDEV}", "-monitor", "stdio",
                *(["-icount", f"shift={ICOUNT_SHIFT}"] if icount else []), "-S",
                "-name", "hil-target,debug-threads=on", *extra_args]
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, close_fds=True,
                                     start_new_session=True)   # Ctrl-C reaches the bench only
        self._stderr_reader = threading.Thread(target=self._drain_stderr, daemon=True)
        self._stderr_reader.start()
        self.monitor = HumanMonitor(self.proc, f"{QEMU} (pid {self.proc.pid})")
        try:
            self._start()
        except LinkError as exc:
            self._abandon()
            raise LinkError(f"{exc}; {self.death_message()}") from None

    def _start(self) -> None:
        self.monitor.greeting(START_TIMEOUT_S)
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            self._sock.connect(self.socket_path)
        except OSError as exc:
            raise LinkError(f"cannot connect to QEMU's USART1 at {self.socket_path}: "
                            f"{exc.strerror}") from None
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:   # QEMU accepts in its main loop: until then it would drop the guest's octets
            name = self.monitor.chardev_filenames().get(SOCKET_CHARDEV, "")
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
        self.monitor.command("cont")   # the CPU runs only now: the bench is listening

    def _drain_stderr(self) -> None:
        for line in self.proc.stderr:
            self.stderr_tail.append(line.decode("utf-8", "replace").rstrip())

    # -- what the target says about itself --------------------------------------------------
    def read_stats(self) -> TargetStats:
        try:
            data = self.monitor.read_memory(STATS_ADDR, TargetStats.words())
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
        tail = "\n    ".join(list(self.stderr_tail) + list(self.monitor.other_lines)) or "(no output)"
        if code is None:
            fault = self._target_fault()
            if fault:
                return f"{fault}; {QEMU} (pid {self.proc.pid}) still runs"
            return f"the firmware in {QEMU} (pid {self.proc.pid}) stopped answering; stderr:\n    {tail}"
        how = f"killed by signal {-code}" if code < 0 else f"exited with code {code}"
        return f"{QEMU} {how}; its last stderr lines:\n    {tail}"

    def cpu_seconds(self) -> float | None:
        """User + system CPU time of the emulator process so far (Linux /proc), None if gone."""
        try:
            with open(f"/proc/{self.proc.pid}/stat") as f:
                after_name = f.read().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            return None
        return (int(after_name[11]) + int(after_name[12])) / os.sysconf("SC_CLK_TCK")

    def stop(self, timeout_s: float = 2.0) -> int | None:
        """Read the target's statistics, close the link, quit QEMU (kill it if it lingers)."""
        if self.proc.poll() is None:
            try:
                st = self.read_stats()
                st.elf, st.elf_sha256 = self.elf.name, _sha256(self.elf)
                st.emulator_cpu_s = self.cpu_seconds()
                self.target_stats = st
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
                self.monitor.command("quit", timeout_s=timeout_s, expect_reply=False)
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
