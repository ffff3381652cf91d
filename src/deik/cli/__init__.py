"""The `deik` command line: one module per command."""

from deik.cli.main import main

__all__ = ["main"]
