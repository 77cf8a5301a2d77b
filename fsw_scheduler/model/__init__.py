"""Formats and their rules: the problem, the plan, goals and changes.

Pure: imports nothing but msgspec and the standard library, never reads the
clock, starts no thread.
"""
