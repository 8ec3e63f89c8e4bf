"""The papers' claims as data: the definitions (``model``: Rule, Run, Quantity, Relation, Claim,
the metric names), the registry read from one TOML file per paper (``registry``: CLAIMS), and
the named rules that expand a family of rows (``expand``). Nothing here imports the rest of the
bench, so a scenario can ask whether a claim id exists without loading the evaluation
(hil_bench.papers.claims) or the metrics on a recording (hil_bench.papers.claim_metrics)."""
