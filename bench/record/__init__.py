"""Recordings: the channels (one definition with the engine's rows), the recorder process that
drains the engine's ring into MCAP, the streaming reader, ``bench recover``, the serial byte
capture beside a serial recording, and what a recording says about its own run: its integrity
(complete, undamaged, clean link, the estimator under test) and its faults' outcomes."""
