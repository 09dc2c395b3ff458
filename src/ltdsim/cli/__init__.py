"""The ``ltdsim`` command: one module per command group (``run``, ``gear`` with
``reduce``, ``curve``, ``analyse``, ``sweep``, ``makeup``, ``study``), each validating its options,
calling the library and printing what it returns, with one clear line for bad input;
``common`` holds what they share (consoles, options, checks, tables) and ``app`` gathers
them into one typer application.

Nothing is computed here that the library does not offer. May import every other
layer; nothing imports it.
"""
