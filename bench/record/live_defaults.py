"""The live view's defaults (docs/foxglove.md), apart from the view itself so the command line can
name them without loading the recorder's C module."""

DEFAULT_PORT = 8765
DEFAULT_HOST = "127.0.0.1"
DEFAULT_RATE_HZ = 50.0
DEFAULT_BACKLOG = 256
#: --live-wait without a value: how long the bench waits for the first viewer [s]
DEFAULT_WAIT_S = 300.0
