"""Solver backends. Only :mod:`fsw_scheduler.solvers.ilp` imports PuLP."""
