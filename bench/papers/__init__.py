"""The papers' claims: metrics of a recording, the claims registry and its rules, ``bench check``
(integrity + metrics + claims of one recording), the studies and runs beyond the papers, and the
claims report (``bench claims --run``) with its plots; the Yuan dead-time calibration."""
