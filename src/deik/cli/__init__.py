"""The `deik` command line: one module per command."""

from deik.cli.app import main

__all__ = ["main"]
