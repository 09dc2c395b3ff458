"""The ``ltdsim`` command: one typer application whose commands validate their options,
call the library and print what it returns, with one clear line for bad input.

Nothing is computed here that the library does not offer. May import every other
layer; nothing imports it.
"""
