"""Exceptions of the protocol package (codec and framing).

Every error is a ``ProtocolError``, itself a ``ValueError``, so callers that only care about "bad input"
can catch ``ValueError``.
"""
from __future__ import annotations


class ProtocolError(ValueError):
    """Base class of every protocol error."""


class UnknownMessageError(ProtocolError):
    """A frame id that is not in protocol/hil.dbc."""


class LengthError(ProtocolError):
    """A payload whose length does not match the message length of the DBC."""


class SignalRangeError(ProtocolError):
    """A physical value outside the DBC [min|max] of its signal (or NaN)."""


class FramingError(ProtocolError):
    """A frame that cannot be put on the serial wire (id > 0x7FF, more than 64 data octets)."""
