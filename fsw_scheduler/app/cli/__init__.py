"""The ``fsw-scheduler`` command line: parser, handlers, entry point.

:mod:`.parser` builds the parser (one ``add_<command>_command`` per
command, in :mod:`.files_flags` or :mod:`.bus_flags`), :mod:`.commands`
holds the handlers, :mod:`.main` parses, dispatches and maps errors to
exit codes; ``run`` is the node's composition root
(:mod:`fsw_scheduler.app.cli.run`).
"""
