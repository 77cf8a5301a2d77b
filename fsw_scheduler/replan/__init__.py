"""The paper's rescheduling rules: execution state, removals, triggers.

Pure: no solver, no bus, no clock. A replan is a new problem and a warm
plan; solving it is left to the caller.
"""
