"""Exception hierarchy of pyheracles.

Every error that a user can fix by changing the input is an :class:`InputError`
(the CLI turns it into a message and exit code 2).  Messages name the file when
there is one and say what to do about it.
"""

from __future__ import annotations

from os import PathLike

__all__ = [
    "CRSMismatchError",
    "DegenerateGeometryError",
    "EstimationError",
    "HeraclesError",
    "InputError",
]


class HeraclesError(Exception):
    """Base class of every error raised by pyheracles."""


class InputError(HeraclesError, ValueError):
    """Input that cannot be processed as given: empty, NaN, unreadable, inconsistent.

    Parameters
    ----------
    message
        What is wrong.
    path
        The file concerned, if any; it is named at the start of the message.
    hint
        What the user can do about it; appended to the message.
    """

    def __init__(
        self, message: str, *, path: str | PathLike[str] | None = None, hint: str | None = None
    ) -> None:
        self.path = None if path is None else str(path)
        self.hint = hint
        text = message if self.path is None else f"{self.path}: {message}"
        if hint:
            text = f"{text}. Fix: {hint}"
        super().__init__(text)


class CRSMismatchError(InputError):
    """Two inputs are in different coordinate reference systems."""


class DegenerateGeometryError(InputError):
    """Geometry that defines nothing: collinear points, zero-area polygons, a single point."""


class EstimationError(HeraclesError):
    """An estimation (fit, adjustment, registration) failed to give a usable result."""
