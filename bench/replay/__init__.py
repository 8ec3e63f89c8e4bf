"""``bench replay``: rerun logged captures offline through the reference estimators, into a live
controller, or into the plant (docs/replay.md)."""
from .capture import Anomalies, Capture, CaptureError
from .modes import MODES, ReplayError, ReplayOptions, ReplayResult
from .readers import read_capture
from .run import run_replay

__all__ = ["Anomalies", "Capture", "CaptureError", "MODES", "ReplayError", "ReplayOptions",
           "ReplayResult", "read_capture", "run_replay"]
