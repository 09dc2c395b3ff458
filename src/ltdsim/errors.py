"""Exceptions raised by ltdsim for bad input and failed simulations."""

from __future__ import annotations


class LtdsimError(Exception):
    """Base class of every error ltdsim raises on purpose."""


class ScenarioError(LtdsimError, ValueError):
    """A scenario file or override is invalid.

    The message names the source (file or override), the dotted key and the
    allowed values or range, one problem per line.
    """

    def __init__(self, source: str, problems: list[tuple[str, str]]):
        self.source = source
        self.problems = problems
        lines = [f"{source}: {key}: {msg}" if key else f"{source}: {msg}" for key, msg in problems]
        super().__init__("\n".join(_printable(line) for line in lines))


def _printable(text: str) -> str:
    """``text`` with control and other unprintable characters escaped (``\\x1e``): a
    key or value read from a file may hold them, and a problem must stay one line."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


class SimulationError(LtdsimError, RuntimeError):
    """A simulation stopped because its state became non-finite.

    Attributes
    ----------
    time : float
        Simulated time of the first non-finite state, s.
    vehicle : int or None
        Index of the first vehicle (0 = lead) whose position or speed is not finite.
    """

    def __init__(self, message: str, time: float, vehicle: int | None = None,
                 coupler: int | None = None):
        self.time = time
        self.vehicle = vehicle
        self.coupler = coupler
        super().__init__(message)
