"""Independent double-precision formulations of the estimators, used only by the tests.

Written from the papers' equations with numpy/scipy, not from the C: each C float32 estimator
is checked against its model on the same inputs with a stated tolerance.
"""
