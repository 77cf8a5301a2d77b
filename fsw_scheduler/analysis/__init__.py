"""Pure algorithms on a problem: domains, proofs, the checker, greedy.

None of these needs a solver; the checker is independent of the ILP.
"""
