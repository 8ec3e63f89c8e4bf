"""Link budget of the per-cycle traffic: serial (COBS framing, 8N1) and CAN / CAN FD.

One control cycle k moves, strictly one after the other (DUTY(k) depends on SENSE(k)):

* uplink (plant -> controller): SENSE_AUX, SENSE_DUAL if HELLO flags bit0, then SENSE;
* downlink (controller -> plant): TELEM, TELEM_EMF if HELLO flags bit1, then DUTY.

So a full-duplex UART gains nothing from its two wires within a cycle: the cycle takes the uplink time
plus the downlink time (plus computation and latencies, ignored here: these are upper bounds).
A CAN bus is shared by both directions anyway.

CAN frame lengths are worst case (maximum bit stuffing), 11-bit identifiers, and include the 3-bit
interframe space:

* classic CAN (Davis, Burns, Bril, Lukkien 2007): ``8 n + 47 + floor((34 + 8 n - 1) / 4)`` bits for n data
  octets; 135 bits for n = 8;
* CAN FD (ISO 11898-1:2015): arbitration phase SOF, id, RRS, IDE, FDF, res, BRS = 17 bits (+ at most 4
  stuff bits) and CRC delimiter, ACK, ACK delimiter, EOF, IFS = 13 bits at the nominal rate; data phase
  ESI, DLC, data, the remaining dynamic stuff bits (at most ``floor((22 + 8 n - 1) / 4)`` in SOF..data),
  stuff count (4), CRC (17 bits up to 16 octets, 21 above) and its fixed stuff bits
  (``1 + floor((4 + crc - 1) / 4)``) at the data rate when BRS is used.
"""
from __future__ import annotations

import math

from . import dbc, framing

BITS_PER_UART_BYTE = 10  #: 8N1: start + 8 data + stop
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)  #: valid CAN FD payload sizes

_FLAG = {f.name: f.mask for f in dbc.flag_table("HelloFlag").bits}
DUAL_SAMPLING = _FLAG["DUAL_SAMPLING"]  #: HELLO flags bit0: SENSE_DUAL every cycle
TELEM_EMF = _FLAG["TELEM_EMF"]  #: HELLO flags bit1: TELEM_EMF every cycle
FLAG_COMBINATIONS = (0, DUAL_SAMPLING, TELEM_EMF, DUAL_SAMPLING | TELEM_EMF)


def flags_name(flags: int) -> str:
    names = [n for n, m in (("dual sampling", DUAL_SAMPLING), ("TELEM_EMF", TELEM_EMF)) if flags & m]
    return " + ".join(names) if names else "base"


def cycle_messages(flags: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(uplink, downlink) message names of one control cycle, in sending order (the trigger last)."""
    up = ("SENSE_AUX",) + (("SENSE_DUAL",) if flags & DUAL_SAMPLING else ()) + ("SENSE",)
    down = ("TELEM",) + (("TELEM_EMF",) if flags & TELEM_EMF else ()) + ("DUTY",)
    return up, down


def _lengths(names: tuple[str, ...]) -> list[int]:
    return [dbc.message_spec(n).length for n in names]


# ---------------------------------------------------------------------------------------------------------
# Serial
# ---------------------------------------------------------------------------------------------------------

def serial_frame_bytes(payload_len: int) -> int:
    """Octets on the wire for one frame with ``payload_len`` data octets (COBS + delimiter included).
    COBS adds exactly one octet below 254 raw octets, whatever the data."""
    return len(framing.encode_frame(0, bytes(payload_len)))


def serial_bytes_per_cycle(flags: int) -> int:
    """Octets per control cycle, both directions (they are sequential within a cycle)."""
    up, down = cycle_messages(flags)
    return sum(serial_frame_bytes(n) for n in _lengths(up + down))


def serial_max_rate_hz(baud: float, flags: int) -> float:
    """Highest cycle rate the UART can carry at ``baud`` (8N1), ignoring computation and latency."""
    return baud / BITS_PER_UART_BYTE / serial_bytes_per_cycle(flags)


# ---------------------------------------------------------------------------------------------------------
# CAN
# ---------------------------------------------------------------------------------------------------------

def fd_payload_size(n: int) -> int:
    """Smallest valid CAN FD payload size holding ``n`` octets."""
    for size in FD_LENGTHS:
        if size >= n:
            return size
    raise ValueError(f"{n} octets do not fit a CAN FD frame (at most 64)")


def _fd_bits(n: int) -> tuple[int, int]:
    """(nominal-rate bits, data-rate bits) of a worst-case CAN FD frame with an 11-bit id."""
    n = fd_payload_size(n)
    arbitration = 17  # SOF, 11-bit id, RRS, IDE, FDF, res, BRS
    stuff_total = (arbitration + 5 + 8 * n - 1) // 4  # dynamic stuffing from SOF to the end of data
    stuff_arbitration = (arbitration - 1) // 4
    crc = 17 if n <= 16 else 21
    fixed_stuff = 1 + (4 + crc - 1) // 4
    nominal = arbitration + stuff_arbitration + 1 + 1 + 1 + 7 + 3  # + CRC delim, ACK, ACK delim, EOF, IFS
    data = 1 + 4 + 8 * n + (stuff_total - stuff_arbitration) + 4 + crc + fixed_stuff  # ESI..CRC
    return nominal, data


def can_frame_bits(dlc: int, fd: bool = False, brs_bitrate: float | None = None,
                   bitrate: float = 1_000_000) -> float:
    """Worst-case length of one frame (11-bit id, interframe space included) in nominal bit times.

    ``dlc`` is the number of data octets (CAN FD: rounded up to a valid size). With CAN FD and
    ``brs_bitrate`` (bit rate switch), data-phase bits count ``bitrate / brs_bitrate`` each."""
    if not fd:
        if not 0 <= dlc <= 8:
            raise ValueError(f"classic CAN carries 0..8 octets, not {dlc}")
        if brs_bitrate is not None:
            raise ValueError("bit rate switching needs CAN FD")
        return 8 * dlc + 47 + (34 + 8 * dlc - 1) // 4
    nominal, data = _fd_bits(dlc)
    if brs_bitrate is None:
        return nominal + data
    return nominal + data * bitrate / brs_bitrate


def can_frame_time_s(dlc: int, bitrate: float, fd: bool = False, data_bitrate: float | None = None) -> float:
    """Worst-case duration of one frame on the bus."""
    return can_frame_bits(dlc, fd=fd, brs_bitrate=data_bitrate, bitrate=bitrate) / bitrate


def can_bits_per_cycle(bitrate: float, flags: int, fd: bool = False, data_bitrate: float | None = None,
                       bundle: bool = False) -> float:
    """Nominal bit times per control cycle. ``bundle`` (CAN FD only): one frame per direction carrying
    all of that direction's messages back to back (payload rounded up to a valid FD size)."""
    up, down = cycle_messages(flags)
    if bundle:
        if not fd:
            raise ValueError("bundling several messages in one frame needs CAN FD")
        frames = [sum(_lengths(up)), sum(_lengths(down))]
    else:
        frames = _lengths(up + down)
    return sum(can_frame_bits(n, fd=fd, brs_bitrate=data_bitrate, bitrate=bitrate) for n in frames)


def can_max_rate_hz(bitrate: float, flags: int, fd: bool = False, data_bitrate: float | None = None,
                    bundle: bool = False) -> float:
    """Highest cycle rate the bus can carry (100 % load, worst-case stuffing, no computation time)."""
    return bitrate / can_bits_per_cycle(bitrate, flags, fd=fd, data_bitrate=data_bitrate, bundle=bundle)


def can_link_name(bitrate: float, fd: bool = False, data_bitrate: float | None = None) -> str:
    """``classic CAN 1 Mbit/s``, ``CAN FD 1 Mbit/s, data phase 5 Mbit/s (BRS)``, ``CAN FD 500 kbit/s``."""
    def rate(b: float) -> str:
        return f"{b / 1e6:g} Mbit/s" if b >= 1e6 else f"{b / 1e3:g} kbit/s"

    if not fd:
        return f"classic CAN {rate(bitrate)}"
    if data_bitrate is None:
        return f"CAN FD {rate(bitrate)}"
    return f"CAN FD {rate(bitrate)}, data phase {rate(data_bitrate)} (BRS)"


def can_bus_load(rate_hz: float, bitrate: float, flags: int, fd: bool = False,
                 data_bitrate: float | None = None) -> float:
    """Worst-case bus load (0..1+) of the per-cycle frames at ``rate_hz`` cycles per second."""
    return rate_hz / can_max_rate_hz(bitrate, flags, fd=fd, data_bitrate=data_bitrate)


def can_fit_period_us(bitrate: float, flags: int, fd: bool = False, data_bitrate: float | None = None,
                      load: float = 0.9, step_us: float = 25.0) -> float:
    """Shortest control period, a multiple of ``step_us``, whose frames take at most ``load`` of the bus
    (worst-case stuffing): how a CAN scenario picks its period."""
    min_period_us = 1e6 / (load * can_max_rate_hz(bitrate, flags, fd=fd, data_bitrate=data_bitrate))
    return math.ceil(min_period_us / step_us - 1e-9) * step_us


#: (nominal bit rate, CAN FD, data-phase bit rate) of the CAN link table in docs/protocol.md
CAN_LINKS = ((500_000, False, None), (1_000_000, False, None), (1_000_000, True, None),
             (1_000_000, True, 2_000_000), (1_000_000, True, 5_000_000))


def can_link_table() -> str:
    """The per-link budget table of the CAN section of docs/protocol.md: highest cycle rate with one
    frame per message (version 1), worst-case stuffing, and the period a scenario should use (<= 90 %
    bus load)."""
    out = ["| link | 8-octet frame | base | TELEM_EMF | dual sampling + TELEM_EMF | period at <= 90 % load (base) |",
           "|---|---|---|---|---|---|"]
    for bitrate, fd, data in CAN_LINKS:
        frame_us = can_frame_time_s(8, bitrate, fd, data) * 1e6
        rates = " | ".join(f"{_hz(can_max_rate_hz(bitrate, f, fd=fd, data_bitrate=data))} Hz"
                           for f in (0, TELEM_EMF, DUAL_SAMPLING | TELEM_EMF))
        out.append(f"| {can_link_name(bitrate, fd, data)} | {frame_us:.1f} us | {rates} | "
                   f"{can_fit_period_us(bitrate, 0, fd=fd, data_bitrate=data):g} us |")
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------------------------------------------------
# Tables for docs/protocol.md (protocol/gen_docs.py)
# ---------------------------------------------------------------------------------------------------------

SERIAL_BAUDS = (115_200, 921_600, 2_000_000, 3_000_000)
CAN_BITRATES = (500_000, 1_000_000)


def _hz(x: float) -> str:
    return f"{math.floor(x):,}".replace(",", " ")


def markdown_tables() -> str:
    """The budget section of docs/protocol.md."""
    out = []
    out.append(f"Serial: one frame with 8 data octets = {serial_frame_bytes(8)} octets on the wire "
               f"({BITS_PER_UART_BYTE} bits each, 8N1). Max cycle rate = baud / 10 / octets per cycle.\n")
    out.append("| per-cycle frames | frames | octets/cycle | " + " | ".join(
        f"{b / 1e6:g} Mbaud" if b >= 1e6 else f"{b} baud" for b in SERIAL_BAUDS) + " |")
    out.append("|---|---|---|" + "---|" * len(SERIAL_BAUDS))
    for flags in FLAG_COMBINATIONS:
        up, down = cycle_messages(flags)
        out.append(f"| {flags_name(flags)} (flags 0x{flags:02X}) | {len(up) + len(down)} | "
                   f"{serial_bytes_per_cycle(flags)} | "
                   + " | ".join(f"{_hz(serial_max_rate_hz(b, flags))} Hz" for b in SERIAL_BAUDS) + " |")
    out.append("")
    out.append(f"Classic CAN, worst-case stuffing: one 8-octet frame = {can_frame_bits(8):g} bits "
               f"(8n + 47 + floor((34 + 8n - 1)/4), interframe space included).\n")
    out.append("| per-cycle frames | bits/cycle | " + " | ".join(f"{b // 1000} kbit/s" for b in CAN_BITRATES)
               + " |")
    out.append("|---|---|" + "---|" * len(CAN_BITRATES))
    for flags in FLAG_COMBINATIONS:
        out.append(f"| {flags_name(flags)} | {can_bits_per_cycle(1e6, flags):g} | "
                   + " | ".join(f"{_hz(can_max_rate_hz(b, flags))} Hz" for b in CAN_BITRATES) + " |")
    out.append("")
    fd8 = can_frame_bits(8, fd=True, brs_bitrate=5e6, bitrate=1e6)
    fd64 = can_frame_bits(64, fd=True, brs_bitrate=5e6, bitrate=1e6)
    n8, d8 = _fd_bits(8)
    n64, d64 = _fd_bits(64)
    out.append(f"CAN FD at 1 Mbit/s nominal, 5 Mbit/s data phase (BRS), worst-case stuffing: an 8-octet frame "
               f"= {n8} nominal + {d8} data-phase bits = {can_frame_time_s(8, 1e6, True, 5e6) * 1e6:.1f} us; "
               f"a 64-octet frame = {n64} + {d64} bits = {can_frame_time_s(64, 1e6, True, 5e6) * 1e6:.1f} us "
               f"({fd8:g} and {fd64:g} nominal bit times). \"Bundled\" = one FD frame per direction carrying "
               "that direction's messages; \"64-octet\" = two full 64-octet frames per cycle (the upper bound "
               "of any bundling).\n")
    out.append("| per-cycle frames | FD, one frame per message | FD, bundled | FD, two 64-octet frames |")
    out.append("|---|---|---|---|")
    for flags in FLAG_COMBINATIONS:
        per_msg = can_max_rate_hz(1e6, flags, fd=True, data_bitrate=5e6)
        bundled = can_max_rate_hz(1e6, flags, fd=True, data_bitrate=5e6, bundle=True)
        out.append(f"| {flags_name(flags)} | {_hz(per_msg)} Hz | {_hz(bundled)} Hz | {_hz(1e6 / (2 * fd64))} Hz |")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    print(markdown_tables())
