"""Closing the loop: the runner (``runner.run_scenario``) sets a scenario's run up (plant,
controller, link, handshake, recorder), starts the C cycle engine and watches it; the links to
a controller (``links``: serial, CAN, the stub), the host side of the protocol session
(``host_session``) and the scenario's faults as engine events (``fault_events``)."""
