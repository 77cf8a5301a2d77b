"""Formats and their rules: the problem, the plan, goals and changes.

Pure: imports nothing but msgspec and the standard library, never reads the
clock, starts no thread.
"""

# Named by the goal format's documentation (and so by the published JSON
# Schemas, which carry it): ``fsw_scheduler.model.id_issue``.
from .limits import id_issue as id_issue
