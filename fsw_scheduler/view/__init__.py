"""Pictures and text views of plans, profiles and recorded sessions.

Only this package imports matplotlib, and only inside functions.
"""
