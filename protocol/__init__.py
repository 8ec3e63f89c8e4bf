"""The hil-bench wire protocol (docs/protocol.md), derived from protocol/hil.dbc.

* ``hil_bench.protocol.messages``: message codec (``MESSAGES``, ``BY_ID``, ``decode``, value-table enums);
* ``hil_bench.protocol.framing``: serial framing (COBS + CRC-16), ``encode_frame`` and ``Deframer``;
* ``hil_bench.protocol.budget``: bytes/bits per control cycle and the resulting maximum cycle rates;
* ``hil_bench.protocol.dbc``: the checked DBC specifications everything above (and the generators) derive from;
* generators: ``gen_c.py`` (protocol/c/hil_msgs.[ch]), ``vectors/gen_vectors.py``, ``gen_docs.py``.
"""
