"""`deik experiments NAME|all [--quick] --out DIR`: regenerate the paper's figures.

Each experiment writes NAME.png, NAME.csv (one row per seed or run) and NAME.md (its report
section) into DIR; running more than one also writes DIR/report.md, every section behind a
side-by-side table of the paper's claims and our measurements. `--doc PATH` (with `all`)
writes that report to PATH too, its pictures copied to figures/ beside it: this is how
docs/paper-reproduction.md and docs/figures/ are made. Bad input gets one line on stderr,
`deik: error: ...`, and exit status 2, as for every deik command.

In Python, `deik.run_experiments(["fig7"], "figures", quick=True)` runs them and returns their
sections (deik.experiments.shared.Section: title, claim, headline, notes, seconds).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import time
from collections.abc import Callable

from deik.console import Parser, configure_logging, progress_bar, show_progress
from deik.errors import DeikError, UsageError, error_line
from deik.experiments import fig2_chain, fig3_population, fig6_comfort, fig7_selection, fig8_timing, fig9_speedup
from deik.experiments.fig45_humanoid import run_fig4, run_fig5
from deik.experiments.flags import DEVICES, SUMMARY, add_arguments
from deik.experiments.shared import Section, markdown_table
from deik.experiments.timing import GPU_COMMAND, machine_line
from deik.io.atomic import all_or_nothing, save_atomically, write_text_atomically

PROG = "deik experiments"
USAGE_ERROR = 2
INTERRUPTED = 130  # 128 + SIGINT, as shells report it
EXPERIMENTS = {
    "fig2": fig2_chain.run,
    "fig3": fig3_population.run,
    "fig4": run_fig4,
    "fig5": run_fig5,
    "fig6": fig6_comfort.run,
    "fig7": fig7_selection.run,
    "fig8": fig8_timing.run,
    "fig9": fig9_speedup.run,
}

INTRO = """\
This document is generated: `{command}` ran every experiment of
Kenwright's paper with deik, wrote each figure's picture and raw numbers, and assembled this page.
Each section gives the paper's claim in our words, our measurement, where and why the two differ,
and the command for that figure alone (`deik experiments NAME --out DIR` once deik is installed).

Conventions for every figure. Seeds are fixed (0, 1, ..., n - 1), so a rerun gives the same
numbers except timings. Where seeds are solved together as one batch, each batch member draws its
own random stream (deik's counter-based generator is keyed on the problem's index). A chain has
converged when its tip is within 1 % of its reach (the paper's criterion). We give medians with
quartiles (or min/max) and the number of seeds, and count runs that never converged within the
budget as "never" instead of dropping them. DE uses F = 0.5 throughout: the paper's printed FW = 2
makes DE diverge. "rand/1/bin" with CR 0.5 is the paper's Algorithm 1 (`deik.Settings.paper()`);
deik's DE is current-to-best/1/bin with F 0.5, CR 0.9. Every figure measures evolution alone:
the LM polish, jDE rates and restarts that deik's solver adds by default are off.

Machine: {machine}. Load average before the run: {load}. Total time: {total:.0f} s ({mode}).
"""


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of `python -m deik.experiments` (the same flags as `deik experiments`)."""
    parser = Parser(prog=PROG, description=f"{SUMMARY[0].upper()}{SUMMARY[1:]}.")
    add_arguments(parser)
    return parser


def resolve(names: list[str]) -> list[str]:
    """Experiment names in run order; "all" means every one. UsageError on an unknown name."""
    unknown = [n for n in names if n != "all" and n not in EXPERIMENTS]
    if unknown:
        raise UsageError(f"unknown experiment {unknown[0]!r}; choose from {', '.join(EXPERIMENTS)} or all")
    return list(EXPERIMENTS) if "all" in names else [n for n in EXPERIMENTS if n in names]


def _check_paths(args, names: list[str]) -> None:
    out = os.path.abspath(args.out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise UsageError(f"--out {args.out!r} is a file, not a folder")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as error:
        raise UsageError(f"--out {args.out!r}: cannot create the folder ({error.strerror or error})") from None
    if not os.access(out, os.W_OK):
        raise UsageError(f"--out {args.out!r}: the folder is not writable")
    if args.doc is not None:
        if names != list(EXPERIMENTS):
            raise UsageError("--doc needs all experiments (NAME all), so the document holds every figure")
        if os.path.isdir(args.doc) or not os.path.isdir(os.path.dirname(os.path.abspath(args.doc))):
            raise UsageError(f"--doc {args.doc!r} must be a file in an existing folder")
        if not args.doc.lower().endswith(".md"):
            raise UsageError(f"--doc {args.doc!r}: the report is Markdown; give a PATH.md")


def report(sections: list[Section], command: str, total: float, quick: bool, load: str, image_prefix: str = "") -> str:
    """The combined markdown report: intro, side-by-side table, every section. Image links
    are `image_prefix` + NAME.png."""
    rows = [[s.title.split(":")[0], s.claim, s.headline] for s in sections]
    parts = [
        "# Reproducing the paper's evaluation",
        "",
        INTRO.format(
            command=command,
            machine=machine_line(),
            load=load,
            total=total,
            mode="quick sizes" if quick else "full sizes",
        ),
        "## Claims and measurements side by side",
        "",
        markdown_table(["figure", "paper", "deik"], rows),
        "",
    ]
    pending = [s.name for s in sections if s.notes]
    if pending:
        parts += [
            f"GPU columns of {', '.join(pending)} are pending: they need a run on a machine with a CUDA GPU: "
            f"`{GPU_COMMAND}`.",
            "",
        ]
    parts += [s.markdown(f"{image_prefix}{s.name}.png") for s in sections]
    return "\n".join(parts)


def _copy(source: str, target: str) -> None:
    if os.path.exists(target) and os.path.samefile(source, target):
        return
    with open(source, "rb") as original:
        save_atomically(target, lambda file: shutil.copyfileobj(original, file))


def run_experiments(
    names: list[str],
    out_dir: str,
    *,
    quick: bool = False,
    device: str = "auto",
    progress: bool | None = False,
    on_section: Callable[[Section], object] | None = None,
) -> list[Section]:
    """Run the experiments `names` (fig2 ... fig9, or "all") into `out_dir` (created if
    missing): each writes NAME.png, NAME.csv and NAME.md there (`report` combines their
    sections). `quick`: few seeds, small sizes; `device` "auto", "cpu" or "gpu" for the GPU
    parts of fig8 and fig9; a bar over the figures with `progress` (deik.console.progress_bar's
    `show`); `on_section(section)` is called as each one finishes. Each figure's PNG, CSV and
    section appear together or not at all (deik.io.atomic), so an interrupted run keeps the
    figures it finished whole. Returns their Sections."""
    names = resolve(names)
    if device not in DEVICES:
        raise UsageError(f"device {device!r}: use one of {', '.join(DEVICES)}")
    os.makedirs(out_dir, exist_ok=True)
    sections = []
    with progress_bar(len(names), PROG, "figure", progress) as bar:
        for name in names:
            bar.set_postfix_str(name)
            began = time.perf_counter()
            with all_or_nothing():
                section = EXPERIMENTS[name](out_dir, quick=quick, device=device)
                section.seconds = time.perf_counter() - began
                section.write(out_dir)
            sections.append(section)
            bar.update()
            if on_section is not None:
                with bar.external_write_mode():  # its lines go above the bar, not through it
                    on_section(section)
    return sections


def run(args: argparse.Namespace) -> int:
    """`deik experiments`: check the flags, run the experiments, say where each one went, and
    with --doc write the report and its pictures there. Ctrl-C and a full disk end in one line
    that names the figures kept whole; the report and the document appear together or not at all."""
    names = resolve(args.names)
    _check_paths(args, names)
    from deik.viz.plot import require_matplotlib

    require_matplotlib()
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "unknown"
    start = time.perf_counter()
    finished: list[Section] = []

    def say(section: Section) -> None:
        finished.append(section)
        name = section.name
        print(f"{name}: {section.seconds:.1f} s -> {os.path.join(args.out, name)}.{{png,csv,md}}", flush=True)
        for note in section.notes:
            print(f"{name}: note: {note}", flush=True)

    try:
        run_experiments(
            names, args.out, quick=args.quick, device=args.device, progress=show_progress(args), on_section=say
        )
        _write_report(args, finished, time.perf_counter() - start, load)
    except KeyboardInterrupt:
        kept = ", ".join(s.name for s in finished) or "none"
        print(
            f"deik: interrupted; the figures finished are kept whole ({kept}), nothing else was written",
            file=sys.stderr,
        )
        return INTERRUPTED
    except OSError as error:  # a full disk, a folder that turned read-only
        kept = ", ".join(s.name for s in finished) or "none"
        print(f"deik: error: {error_line(error)}; the figures finished are kept whole ({kept})", file=sys.stderr)
        return USAGE_ERROR
    return 0


def _write_report(args: argparse.Namespace, sections: list[Section], total: float, load: str) -> None:
    """With more than one section, DIR/report.md; with --doc, the document and its pictures
    in figures/ beside it: all or none."""
    quick = " --quick" if args.quick else ""
    command = f"PYTHONPATH=src python -m deik.experiments {' '.join(args.names)}{quick} --out DIR"
    if args.doc:
        command += f" --doc {os.path.relpath(args.doc)}"
    figures = os.path.join(os.path.dirname(os.path.abspath(args.doc)), "figures") if args.doc else None
    with all_or_nothing():
        if len(sections) > 1:
            write_text_atomically(
                os.path.join(args.out, "report.md"), report(sections, command, total, args.quick, load)
            )
        if figures:
            os.makedirs(figures, exist_ok=True)
            for section in sections:
                _copy(os.path.join(args.out, f"{section.name}.png"), os.path.join(figures, f"{section.name}.png"))
            write_text_atomically(args.doc, report(sections, command, total, args.quick, load, "figures/"))
    if len(sections) > 1:
        print(f"report: {os.path.join(args.out, 'report.md')} ({total:.0f} s in all)")
    if figures:
        print(f"document: {args.doc}, pictures in {figures}")


def main(argv: list[str] | None = None) -> int:
    """`python -m deik.experiments` with `argv` (default sys.argv[1:]); returns the exit status.
    Mistakes print `deik: error: ...` and return 2, as `deik experiments` does."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = build_parser().parse_args(argv)
        configure_logging(args)
        return run(args)
    except SystemExit as done:  # --help
        return int(done.code or 0)
    except (DeikError, ImportError, OSError) as error:
        print(f"deik: error: {error}", file=sys.stderr)
        return USAGE_ERROR
