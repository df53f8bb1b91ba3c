"""The one exception the command line turns into `error: <file>: <field>: <what>`."""
from __future__ import annotations


class UsageError(Exception):
    """Bad user input: reported as one line `error: <file>: <field>: <what>`, exit 2."""
