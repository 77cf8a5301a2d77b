"""Benchmark kit of fsw_scheduler: problem generator, CP-SAT reference model,
runner and report (the paper's "PERFORMANCE ANALYSIS" campaign).

Run it with ``.venv/bin/python tools/bench --help``.
"""
