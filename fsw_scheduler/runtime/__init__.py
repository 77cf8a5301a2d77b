"""Node logic without Zenoh: settings, clock, input decoding, policy.

Shared by the bus node and by replay, so that ``replay --verify`` runs the
same decisions without importing Zenoh.
"""
