"""Node logic without Zenoh: settings, clock, inputs, policy, access.

Shared by the bus node and by replay, so that ``replay --verify`` runs the
same decisions without importing Zenoh.
"""
