"""Errors a user can cause. Each carries one sentence that names the input and what to do."""

from __future__ import annotations


class InkmotionError(Exception):
    """Base of all user-facing errors; ``str(err)`` is the one sentence shown to the user."""


class InputError(InkmotionError):
    """An input file or value is malformed, empty, degenerate or too large."""


class PluginError(InkmotionError):
    """A plugin is unknown, failed to load, or misbehaved."""


class SpecError(InkmotionError):
    """A job specification is invalid."""


class ServiceError(InkmotionError):
    """A service (broker, database) cannot be reached."""


class RobotError(InkmotionError):
    """A robot refused a command, faulted, or was stopped before it finished."""
