"""Solver backends. Only :mod:`fsw_scheduler.solving.ilp` imports PuLP."""
