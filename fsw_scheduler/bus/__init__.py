"""Zenoh shell of fsw_scheduler: sessions, bus recording and replay.

Everything under this package may import :mod:`zenoh`; the pure modules of
:mod:`fsw_scheduler` never import it. Submodules are imported explicitly
(``from fsw_scheduler.bus.session import open_peer_pair``) so that loading
one part of the bus does not load the others.
"""
