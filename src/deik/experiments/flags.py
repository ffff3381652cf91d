"""The flags of `deik experiments`, apart from the experiments themselves so that the command
line can offer them without loading the experiments' kernels (deik.experiments.runner runs them)."""

from __future__ import annotations

import argparse

from deik.console import add_output_flags

NAMES = ("fig2", "fig3", "fig4", "fig5", "fig6", "fig7", "fig8", "fig9")  # runner.EXPERIMENTS, in run order
DEVICES = ("auto", "cpu", "gpu")
SUMMARY = "reproduce the paper's figures: PNG, CSV and a report section each"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The `deik experiments` flags on `parser`."""
    parser.add_argument("names", nargs="+", metavar="NAME|all", help=f"experiments to run: {', '.join(NAMES)}, or all")
    parser.add_argument("--out", required=True, metavar="DIR", help="folder for the outputs (created if missing)")
    parser.add_argument("--quick", action="store_true", help="few seeds, small sizes (seconds, for tests)")
    parser.add_argument(
        "--device",
        choices=list(DEVICES),
        default="auto",
        help="GPU parts of fig8/fig9: auto (when a GPU is present), gpu, or cpu only",
    )
    parser.add_argument(
        "--doc", metavar="PATH.md", help="with all: also write the report to PATH, its pictures in figures/ beside it"
    )
    add_output_flags(parser)
