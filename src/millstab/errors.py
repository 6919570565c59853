"""Errors and warnings that millstab raises for bad input.

Every input problem is reported as one :class:`InputError` whose message names the field, the value
that was given and what is allowed, so the CLI can print it on one line.
"""

from __future__ import annotations


class InputError(ValueError):
    """Invalid user input: names the offending field, its value and what is allowed."""

    def __init__(self, field: str, value: object, allowed: str):
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field} = {value!r} is invalid: {allowed}")


class UnitWarning(UserWarning):
    """A value that is valid but whose magnitude suggests a unit slip (e.g. N/µm read as N/m)."""
