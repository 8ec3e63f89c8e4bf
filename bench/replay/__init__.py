"""``bench replay``: rerun logged captures offline through the reference estimators, into a live
controller, or into the plant (docs/replay.md)."""
from .capture import Anomalies, Capture, CaptureError
from .modes import MODES, ReplayError, ReplayOptions, ReplayResult, run_replay
from .readers import read_capture

__all__ = ["Anomalies", "Capture", "CaptureError", "MODES", "ReplayError", "ReplayOptions",
           "ReplayResult", "read_capture", "run_replay"]
