"""Disjunctive (start-time) ILP of the scheduling problem.

One integer start and one "scheduled" binary per task, and one order
binary per direction of each pair of tasks that could collide on a
resource: :mod:`.variables`, :mod:`.constraints` (one method per
constraint family), :mod:`.objective` and :mod:`.model` (the built model
that :func:`fsw_scheduler.solving.ilp.model.solve_ilp` hands to the same
CBC or HiGHS run). :mod:`.rule` says which parts it is built for.
"""
