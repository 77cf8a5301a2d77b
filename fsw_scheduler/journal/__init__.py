"""MCAP journals: writing, recovering, reading, annotating, replay."""
