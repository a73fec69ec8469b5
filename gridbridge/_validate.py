"""Deprecated alias of :mod:`gridbridge.validation`: kept for pfpeople.pipeline until the split lands."""

from gridbridge.validation import *  # noqa: F403
