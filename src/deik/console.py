"""What deik shows on stderr besides errors: progress bars (tqdm) and log lines (the "deik"
logger), the flags that set both on every command that works for more than a moment, and the
argument parser every command shares (mistakes as UsageError, with close matches).

- Python: nothing unless asked. `deik.solve(..., progress=True)` (also `solve_batch`,
  `Solver.solve`) draws a bar over generations, a callable gets `(generation, best_fitness)`;
  diagnostics go to `logging.getLogger("deik")`, which has no handler of its own.
- Command line: a bar on a terminal once the work has run for DELAY seconds (quick commands
  print none); notes and warnings on stderr; results on stdout.

      --quiet, -q     no progress bar and no notes (warnings and errors still print)
      --verbose, -v   also the diagnostics (level DEBUG: launches, timings, what was loaded)
      --progress      the bar even when stderr is not a terminal (logs, pipes), from the start

  DEIK_LOG=debug|info|warning|error sets the level too; the flags win.
"""

from __future__ import annotations

import argparse
import logging
import os
import re
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING, NoReturn

from deik.errors import InputError, UsageError
from deik.suggest import did_you_mean

if TYPE_CHECKING:  # tqdm is imported when a bar is made
    from tqdm import tqdm

INVALID_CHOICE = re.compile(r"invalid choice: '([^']*)' \(choose from (.*)\)")
DELAY = 1.0  # seconds of work before a bar appears on a terminal: shorter work shows none
LEVELS = {"debug": logging.DEBUG, "info": logging.INFO, "warning": logging.WARNING, "error": logging.ERROR}

# a solve's progress argument: True (a bar), a callable(generation, best_fitness), or None / False (nothing)
Progress = bool | Callable[[int, float], object] | None


def progress_bar(total: int | None, description: str, unit: str, show: bool | None = None) -> tqdm:
    """A tqdm bar on stderr over `total` steps of `unit` (None: a count without an end).
    `show`: True always and at once, None on a terminal after DELAY seconds, False never (a
    disabled bar still takes updates)."""
    from tqdm import tqdm

    return tqdm(
        total=total,
        desc=description,
        unit=unit,
        file=sys.stderr,
        disable=None if show is None else not show,
        delay=0.0 if show else DELAY,
        dynamic_ncols=True,
    )


_compile_bar: bool | None = False  # compile bars: off unless a command (or progress=True) asks


def show_compile_bars(show: bool | None) -> None:
    """Whether kernel compiles draw a bar (progress_bar's `show`; a command sets its flags')."""
    global _compile_bar
    _compile_bar = show


def compile_bars() -> bool | None:
    """The `show` flag of kernel compile bars (show_compile_bars; default False: nothing)."""
    return _compile_bar


def show_generation(bar: tqdm, generation: int, best: float, running: int = 1, problems: int = 1) -> None:
    """Move a solve's `bar` to `generation`, with the best fitness and, for a batch of
    `problems`, how many still run."""
    batch = f", {running}/{problems} problems running" if problems > 1 else ""
    bar.set_postfix_str(f"best fitness {best:.4g}{batch}", refresh=False)
    bar.update(generation - bar.n)


def frames_reporter(bar: tqdm, meeting: str) -> Callable[[int, str], None]:
    """What a clip fix or retarget calls after each stage, report(met_frames, stage): moves
    `bar` (over the clip's frames) to the frames that meet `meeting` ("every goal")."""

    def report(met: int, stage: str) -> None:
        bar.set_postfix_str(f"{stage}: frames meeting {meeting}", refresh=False)
        bar.update(met - bar.n)

    return report


@contextmanager
def generation_reporter(
    progress: Progress, generations: int, problems: int
) -> Iterator[Callable[[int, float, int], None] | None]:
    """What a solve calls after each kernel launch, report(generation, best_fitness, running),
    or None when `progress` asks for nothing. progress=True draws a bar over `generations`
    (shown at once, closed when the block ends); a callable gets (generation, best_fitness)."""
    if progress is None or progress is False:
        yield None
    elif callable(progress):
        yield lambda generation, best, running: progress(generation, best)
    elif progress is True:
        with progress_bar(generations, "deik solve", "gen", show=True) as bar:
            yield lambda generation, best, running: show_generation(bar, generation, best, running, problems)
    else:
        raise TypeError(f"progress must be True, False, None or a callable(generation, best_fitness), got {progress!r}")


def add_output_flags(parser: argparse.ArgumentParser, progress: bool = True) -> None:
    """--quiet and --verbose (one or the other) on a command's `parser`; --progress too when
    the command shows a bar."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--quiet", "-q", action="store_true", help="no progress bar and no notes on stderr (errors still print)"
    )
    group.add_argument("--verbose", "-v", action="store_true", help="also print diagnostics on stderr (DEIK_LOG=debug)")
    if progress:
        parser.add_argument(
            "--progress", action="store_true", help="show the progress bar even when stderr is not a terminal"
        )


def show_progress(args: argparse.Namespace) -> bool | None:
    """progress_bar's `show` for a command's flags: False with --quiet, True with --progress,
    else None (on a terminal, once the work takes a second)."""
    if getattr(args, "quiet", False):
        return False
    return True if getattr(args, "progress", False) else None


class _Lines(logging.Formatter):
    """Notes as they are; other levels behind their name: `warning: ...`, `debug: deik.x: ...`."""

    def format(self, record: logging.LogRecord) -> str:
        message = record.getMessage()
        if record.levelno == logging.INFO:
            return message
        if record.levelno == logging.DEBUG:
            return f"debug: {record.name}: {message}"
        return f"{'warning' if record.levelno == logging.WARNING else 'error'}: {message}"


class _Stderr(logging.StreamHandler):
    """Writes to whatever sys.stderr is when a record comes, so a redirection made after the
    set-up (by tests, or a program that runs deik's main) is honoured."""

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value) -> None:  # StreamHandler.__init__ assigns one; the property rules
        pass


def configure_logging(args: argparse.Namespace | None = None) -> None:
    """Send the "deik" logger to stderr at the level the flags ask for (--verbose debug,
    --quiet warning), else DEIK_LOG's, else info; replaces the handler of an earlier call.
    ValueError for a DEIK_LOG that names no level."""
    level = _level(args)
    logger = logging.getLogger("deik")
    for handler in [h for h in logger.handlers if isinstance(h, _Stderr)]:
        logger.removeHandler(handler)
    handler = _Stderr()
    handler.setFormatter(_Lines())
    logger.addHandler(handler)
    logger.setLevel(level)


def _level(args: argparse.Namespace | None) -> int:
    if getattr(args, "verbose", False):
        return logging.DEBUG
    if getattr(args, "quiet", False):
        return logging.WARNING
    name = os.environ.get("DEIK_LOG", "").strip().lower()
    if name and name not in LEVELS:
        raise InputError(f"DEIK_LOG={name!r} names no level; use one of {', '.join(LEVELS)}, or unset it")
    return LEVELS.get(name, logging.INFO)


# a word that is a negative number (-1e-3, -.5, -1e300, -inf) or a frame range from the end
# (-30:, -5:-1), never an option: argparse's own pattern knows only -1 and -1.5, so
# `--reach tip 1.5 -1e-3 0` failed as if -1e-3 were a flag
NEGATIVE_NUMBER = re.compile(
    r"^-(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^-(inf|infinity|nan)$|^-\d+:(-?\d+)?$", re.IGNORECASE
)


class Parser(argparse.ArgumentParser):
    """argparse that raises UsageError instead of printing usage and exiting: the message says
    which choice or option was meant when one is close, and points to the `--help` of the
    (sub)command whose flags were wrong. Every negative number is read as a value."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str) -> NoReturn:
        choice = INVALID_CHOICE.search(message)
        if choice:
            message += did_you_mean(choice[1], re.findall(r"'([^']*)'", choice[2]))
        raise UsageError(f"{message} (see `{self.prog} --help`)")

    def parse_args(
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> argparse.Namespace:
        """As argparse's, but an unknown option is refused by the subcommand it was given to."""
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            parser = self._chosen(namespace)
            options = [flag for action in parser._actions for flag in action.option_strings]
            unknown = next((word.split("=")[0] for word in extras if word.startswith("-")), "")
            parser.error(f"unrecognized arguments: {' '.join(extras)}{did_you_mean(unknown, options)}")
        return namespace

    def _chosen(self, namespace: argparse.Namespace) -> argparse.ArgumentParser:
        """The innermost subcommand's parser that `namespace` chose (this one without subcommands)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                chosen = action.choices.get(getattr(namespace, action.dest, None))
                if chosen is not None:
                    return chosen._chosen(namespace) if isinstance(chosen, Parser) else chosen
        return self
