"""Composition: the command line, the node's composition root, demos."""
