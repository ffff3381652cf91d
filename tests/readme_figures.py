"""The numbers README.md states beside its commands, and what measures each one, so that a figure
that drifts from its measurement fails a test (tests/cli/test_readme_figures.py, and
tests/cli/test_readme.py for the figures a README command measures).

A number in the prose next to a README command (between the command's block and the code block
or heading before or after it, outside `code spans`) is either
- a FIGURE: measured by a README command's own output (the JSON it writes with --json, or its
  stdout), or by a benchmark's results file under benchmarks/results; the test compares the
  stated number with the measured one within the figure's tolerance; or
- a SETTING: a number that is not a measurement (a flag's value, a threshold deik uses, an exit
  status), listed with the reason.
A number in neither list fails the test, which names it and asks for it to be added to one.
Figures of other documents (docs/install.md's tables) are checked the same way, against the
results files they quote.
"""

from __future__ import annotations

import json
import re
import shlex
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from readme_commands import README, ROOT

from judging.clips import STEP_SLACK

RESULTS = ROOT / "benchmarks" / "results"
# a number as prose writes it: 0.018, -30, 2,000, a range 7-27 (its unit may follow)
NUMBER = re.compile(r"(?<![\w.\-/])-?\d+(?:,\d{3})*(?:\.\d+)?(?:-\d+(?:\.\d+)?)?(?![\w.]*\d)(?!-[A-Za-z])")
FENCE = re.compile(r"```(\w*)\n.*?```", re.S)
HEADING = re.compile(r"^#+ .*$", re.M)
CODE_SPAN = re.compile(r"`[^`]*`")

# How near a stated number must be to its measurement: "shown" (the measurement, rounded to the
# digits the README shows, equals it), "at most" (the README says "no more than"), "at least", or
# a fraction (0.15: within 15 % of the measurement, for a figure stated as "about", and never
# stricter than "shown").
Tolerance = str | float


@dataclass(frozen=True)
class Figure:
    """A measured number of the README: `pattern`, a regex over the README (whitespace collapsed
    to single spaces) matching once, whose groups are the stated numbers; `source`, the README
    command that measures them (the start of its line) or a results file under
    benchmarks/results ("clip_targets.json"); `measure(record)`, the measured values, one per
    group, from the command's record ({"stdout": str, "json": what it wrote with --json}) or
    the results file's JSON; `tolerance`, one for every group or one per group; `document`, the
    file under the checkout that states it (the README unless said)."""

    pattern: str
    source: str
    measure: Callable[[dict], list[float]]
    tolerance: Tolerance | tuple[Tolerance, ...] = "shown"
    document: str = "README.md"

    @property
    def from_results(self) -> bool:
        return self.source.endswith(".json")


def collapsed(text: str) -> str:
    """`text` with every run of whitespace made one space, as the patterns see the README."""
    return " ".join(text.split())


def prose_beside_commands(text: str | None = None) -> list[str]:
    """The prose next to each bash or console block of the README (or `text`), whitespace
    collapsed: from the code block or heading before the block to it, and from it to the next."""
    text = README.read_text() if text is None else text
    stops = sorted(
        [(m.start(), m.end(), m.group(1)) for m in FENCE.finditer(text)]
        + [(m.start(), m.end(), "heading") for m in HEADING.finditer(text)]
    )
    spans = set()
    for k, (start, end, kind) in enumerate(stops):
        if kind in ("bash", "console"):
            if k > 0:
                spans.add((stops[k - 1][1], start))
            if k + 1 < len(stops):
                spans.add((end, stops[k + 1][0]))
    return [collapsed(text[start:end]) for start, end in sorted(spans)]


def numbers_in(prose: str) -> list[re.Match]:
    """The numbers of `prose` outside its `code spans` (flags, names and values typed as code)."""
    code = [m.span() for m in CODE_SPAN.finditer(prose)]
    return [m for m in NUMBER.finditer(prose) if not any(a <= m.start() < b for a, b in code)]


def _library(record: dict, key: str, body: str | None = None) -> list[float]:
    """`key` of every clip retargeted onto every body (or onto `body`) in library.json."""
    bodies = record["quality"] if body is None else {body: record["quality"][body]}
    return [row[key] for rows in bodies.values() for row in rows if row["status"] == "done"]


def _package(record: dict, name: str) -> float:
    """Megabytes of package `name` in a wheel_install record (or its "extras" part)."""
    return next(row["bytes"] for row in record["packages"] if row["name"].lower() == name) / 1e6


def _met(record: dict, target: str) -> int:
    """How many cases of clip_targets.json meet `target` ("sliding", "depth", "peaks", ...)."""
    return sum(bool(case["verdicts"].get(target)) for case in record["cases"])


def _case(record: dict, name: str) -> dict:
    return next(case for case in record["cases"] if case["case"] == name)


def _beside_their_clips(record: dict) -> list[float]:
    """The largest differences of the `_digits` cases from their clips: sliding (mm a frame),
    travel (cm) and depth (mm, the get-up's aside; the foot runs:
    tests/benchmarks/test_bench_clip_targets.py)."""
    pairs = [(case, _case(record, case["case"][: -len("_digits")])) for case in record["cases"]
             if case["case"].endswith("_digits")]  # fmt: skip
    most = [max(abs(a[key] - b[key]) for a, b in pairs) for key in ("sliding_mm_per_frame", "travel_m")]
    depth = max(abs(a["depth_mm"] - b["depth_mm"]) for a, b in pairs if not a["case"].startswith("getup"))
    return [most[0], most[1] * 100.0, depth]


def _span(values: list[float]) -> list[float]:
    return [min(values), max(values)]


TARGETS = "benchmarks/results/clip_targets.json"
PROBE = "benchmarks/results/clip_probe/clip_targets.json"
DRAWS = "benchmarks/results/noise_draws.json"
BALANCE = "deik clip ../shared/data/humanoid/humanoid3d_walk.bvh --balance"

WHEEL = "benchmarks/results/wheel_install.json"
VIEW = "benchmarks/results/wheel_install_view.json"
COLD = "benchmarks/results/cold_start.json"
GPU = "benchmarks/results/gpu/gpu_check.json"


def _gpu_ms(record: dict, row: str) -> float:
    return record["panda"]["rows"][row]["best_ms"]


def _de_rate(record: dict, row: str) -> float:
    return record["evolution"]["rows"][row]["joint_evaluations_per_s"]


def _de_batches(record: dict) -> dict[str, int]:
    """The DE stage's batch on each device that is not one problem: {"gpu": 528, "cpu": 64}."""
    rows = [key.split("/") for key in record["evolution"]["rows"] if not key.endswith("/1")]
    return {device: int(batch) for device, batch in rows}


def _cpu(record: dict, case: str) -> float:
    """CPU seconds of a cold_start case (the median of its fresh processes)."""
    return record["cases"][case]["cpu"]


def _wall(record: dict, case: str) -> float:
    return record["cases"][case]["wall"]


def _cores(record: dict) -> int:
    return record["environment"]["cpu_count"]


FIGURES = (
    Figure(
        r"beside (\d+) CPU cores of the same machine, ([\d,]+) strict Panda targets take (\d+) ms on the GPU and "
        r"(\d+) ms on the CPU; at ([\d,]+) they tie",
        GPU,
        lambda r: [r["environment"]["cpus"], 10000, _gpu_ms(r, "gpu/10000"), _gpu_ms(r, "cpu/10000"), 2000],
    ),
    Figure(r"to the GPU from about ([\d,]+) problems", GPU, lambda r: [r["crossover"]["polish_problems"]], 0.05),
    Figure(
        r"DE on (\d+) problems of (\d+) links runs (\d+)x faster than the CPU on (\d+); one problem alone runs at "
        r"(0\.\d+)x",
        GPU,
        lambda r: [
            _de_batches(r)["gpu"],
            r["evolution"]["rows"]["gpu/1"]["links"],
            _de_rate(r, f"gpu/{_de_batches(r)['gpu']}") / _de_rate(r, f"cpu/{_de_batches(r)['cpu']}"),
            _de_batches(r)["cpu"],
            _de_rate(r, "gpu/1") / _de_rate(r, "cpu/1"),
        ],
    ),
    Figure(
        r"Panda 2,000 strict targets, one batch \| 28 ms \| ([\d.]+) ms \| ([\d.]+) ms \|.*?"
        r"\| Panda 10,000 strict targets \| 131,000/s \| ([\d,]+)/s \((\d+) ms\) \| ([\d,]+)/s \((\d+) ms\) \|.*?"
        r"\| one target on the GPU \| 12\.5 ms \| ([\d.]+) ms \| ([\d.]+) ms \|",
        GPU,
        lambda r: [
            _gpu_ms(r, "gpu/2000"),
            _gpu_ms(r, "cpu/2000"),
            1e4 / _gpu_ms(r, "gpu/10000") * 1e3,
            _gpu_ms(r, "gpu/10000"),
            1e4 / _gpu_ms(r, "cpu/10000") * 1e3,
            _gpu_ms(r, "cpu/10000"),
            _gpu_ms(r, "gpu/1"),
            _gpu_ms(r, "cpu/1"),
        ],
        ("shown", "shown", 0.01, "shown", 0.01, "shown", "shown", "shown"),
        document="docs/gpu.md",
    ),
    Figure(
        r"first GPU solve after install takes (\d+) s \(the kernels compile\), (\d\.\d) s in the next process",
        GPU,
        lambda r: [r["first_solve"]["fresh_cache"]["first_s"], r["first_solve"]["second_process"]["first_s"]],
    ),
    Figure(
        r"says so first \((\d+) s wall and ([\d-]+) s of CPU time on (\d+) cores",
        COLD,
        lambda r: [
            _wall(r, "first solve float32"),
            *_span([_cpu(r, "first solve float32"), _cpu(r, "first solve float64")]),
            _cores(r),
        ],
    ),
    Figure(
        r"([\d-]+) s wall on a day the same machine runs slower",
        "benchmarks/results/compare/cold_start_183beee_ef4dff5.json",
        lambda r: _span(
            [v for f in r["figures"] if f["figure"] == "first solve float32, wall s" for v in f["after"]["values"]]
        ),
    ),
    Figure(r"about (\d+) s of CPU time on 2 cores for both dtypes", COLD, lambda r: [_cpu(r, "warmup")], 0.15),
    Figure(
        r"`pip install \.` brings (\d+) packages and about (\d+) MB",
        WHEEL,
        lambda r: [r["package_count"], r["megabytes"]],
        ("shown", 0.15),
    ),
    Figure(
        r"llvmlite \((\d+) MB\) and NumPy \((\d+) MB\), make (\d+) MB of it; deik's additions beyond them, deik "
        r"itself \(([\d.]+) MB\), lxml and tqdm, make (\d+) MB",
        WHEEL,
        lambda r: [
            _package(r, "llvmlite"),
            _package(r, "numpy"),
            r["numba_stack"]["megabytes"],
            _package(r, "deik"),
            r["deik_additions"]["megabytes"],
        ],
        ("shown", "shown", "shown", 0.15, "shown"),  # deik's own size moves with every change
    ),
    Figure(
        r"on the walk below, (\d+) of its (\d+) frames",
        BALANCE,
        lambda run: [len(run["json"]["balance"]["skipped_frames"]), run["json"]["frames"]],
    ),
    Figure(
        r"The acceleration target holds on all (\d+) cases and the body travels as far as in the capture on (\d+); "
        r"sliding holds on (\d+) and depth on (\d+)",
        TARGETS,
        lambda r: [_met(r, "peaks"), _met(r, "travel"), _met(r, "sliding"), _met(r, "depth")],
    ),
    Figure(
        r"every resting run of the feet is found again \(lifting and landing within ([\d.]+) s of the capture's\) "
        r"on (\d+); (\d+) of the (\d+) cases meet every target",
        TARGETS,
        lambda r: [
            STEP_SLACK,
            _met(r, "steps"),
            sum(all(case["verdicts"].values()) for case in r["cases"]),
            len(r["cases"]),
        ],
    ),
    Figure(
        r"target holds on all (\d+) cases, sliding on (\d+), depth on (\d+) and the listing of misses on (\d+); "
        r"(\d+) meet every target \(`benchmarks/results/clip_probe/`\)",
        PROBE,
        lambda r: [
            len(r["cases"]),
            _met(r, "sliding"),
            _met(r, "depth"),
            _met(r, "listed"),
            sum(all(case["verdicts"].values()) for case in r["cases"]),
        ],  # fmt: skip
    ),
    Figure(
        r"Each `_digits` case measures as its clip does: its sliding within ([\d.]+) mm a frame of the clip's, "
        r"its travel within ([\d.]+) cm, its depth within ([\d.]+) mm but the get-up's",
        TARGETS,
        lambda r: _beside_their_clips(r),
        "at most",
    ),
    Figure(
        r"the get-up's \(([\d.]+) mm under the floor against its clip's ([\d.]+):",
        TARGETS,
        lambda r: [_case(r, "getup_facedown_digits")["depth_mm"], _case(r, "getup_facedown")["depth_mm"]],
    ),
    Figure(
        r"the run's feet, (\d+) mm under the floor in the capture, are (\d+) mm under after",
        TARGETS,
        lambda r: [_case(r, "run")["depth_capture_mm"], _case(r, "run")["depth_mm"]],
    ),
    Figure(
        r"the jump's heel,\s+(\d+) mm under the floor as it lands, is (\d+) mm under after",
        TARGETS,
        lambda r: [_case(r, "jump")["depth_capture_mm"], _case(r, "jump")["depth_mm"]],
    ),
    Figure(
        r"the kick and the punch on the game\s+rigs with noise at 30 fps slide at most ([\d.]+) mm a frame",
        TARGETS,
        lambda r: [
            max(
                _case(r, f"{clip}_{feet}_noisy")["sliding_mm_per_frame"]
                for clip in ("kick", "punch")
                for feet in ("digits", "toes")
            ),
        ],
        "at most",
    ),
    Figure(
        r"sliding holds on (\d+) cases and the misses are listed on (\d+) \(before this rule: `docs/decisions.md`\); "
        r"(\d+) cases still slide more than 5 mm a frame",
        DRAWS,
        lambda r: [_met(r, "sliding"), _met(r, "listed"), sum(c["sliding_mm_per_frame"] > 5.0 for c in r["cases"])],
    ),
    Figure(
        r"\(`python -m benchmarks.noise_draws`: (\d+) cases of (\d+) clips on (\d+) rig families\)",
        DRAWS,
        lambda r: [
            len(r["cases"]),
            len({"_".join(c["case"].split("_")[:-3]) for c in r["cases"]}),
            len({c["case"].split("_")[-3] for c in r["cases"]}),
        ],
    ),
    Figure(
        r"the last frame of the noisy crawl with bending toes, a knee ([\d.]+) mm under the floor",
        TARGETS,
        lambda r: [_case(r, "crawl_toes_noisy")["depth_mm"]],
    ),
    Figure(
        r"on (\d+) of the (\d+) cases every frame\s+the judge finds missing is among those deik lists",
        TARGETS,
        lambda r: [_met(r, "listed"), len(r["cases"])],
    ),
    Figure(
        r"clip is fixed in ([\d.]+) s on two cores, best of three runs of ([\d.-]+) s",
        "benchmarks/results/clip_frames.json",
        lambda r: [r["best_seconds"], *_span(r["all_seconds"])],
    ),
    Figure(
        r"key points ([\d-]+) mm from their targets on average, no limit violation, contacts sliding at most "
        r"([\d.]+) mm per frame on the robot and ([\d.]+) mm on the humanoid .*?, nothing more than ([\d.]+) mm "
        r"into the floor and bone capsules overlapping by at most ([\d.]+) mm",
        "benchmarks/results/library.json",
        lambda r: [
            *_span(_library(r, "keypoint_error_mean_mm")),
            max(_library(r, "contact_sliding_max_mm_per_frame", "human.urdf")),
            max(_library(r, "contact_sliding_max_mm_per_frame", "deik.humanoid()")),
            max(_library(r, "penetration_max_mm")),
            max(_library(r, "self_penetration_max_mm")),
        ],
    ),
    Figure(
        r"slides at most ([\d.]+) mm per frame over every point resting in the source, goes at most ([\d.]+) mm "
        r"under the floor, takes no joint step past its allowance and no wrap, and keeps each hand within (\d+) mm "
        r"of its scaled source point \(the bound: 0\.1 statures, (\d+) mm on `human\.urdf`\)",
        "benchmarks/results/retarget_quality.json",
        lambda r: [
            max(run["sliding_max_mm_per_frame"] for run in r["runs"]),
            max(run["penetration_max_mm"] for run in r["runs"]),
            max(run["wrist_distance_max_mm"] for run in r["runs"]),
            max(run["wrist_bound_mm"] for run in r["runs"] if run["target"] == "human.urdf"),
        ],
        ("at most", "at most", "at most", "shown"),
    ),
    Figure(
        r"the walk, the run and the kick at\s+120 fps with capture noise slide "
        r"([\d.]+), ([\d.]+) and ([\d.]+) mm a frame",
        "benchmarks/results/retarget_quality.json",
        lambda r: [
            next(run for run in r["runs"] if run["clip"] == clip and run["case"] == "120fps_noisy")[
                "sliding_max_mm_per_frame"
            ]
            for clip in ("walk", "run", "kick")
        ],
    ),
    Figure(
        r"where nothing is filtered, rests are read through the noise as\s+`deik clip` reads them: "
        r"the walk and the kick with capture noise slide ([\d.]+) and ([\d.]+) mm a frame",
        "benchmarks/results/retarget_quality.json",
        lambda r: [
            next(run for run in r["runs"] if run["clip"] == clip and run["case"] == "30fps_noisy")[
                "sliding_max_mm_per_frame"
            ]
            for clip in ("walk", "kick")
        ],
    ),
    Figure(
        r"keeps the Panda's base and wrist within (\d+) degrees of their zero and its elbow between (-\d+) and "
        r"(-\d+) degrees",
        "examples/panda_limits.json",
        lambda r: [r["panda_joint1"][1], r["panda_joint4"][0], r["panda_joint4"][1]],
    ),
    Figure(
        r"`pip install -e \"\.\[view\]\"`, (\d+) packages and (\d+) MB beside deik's own",
        VIEW,
        lambda r: [r["extras"]["package_count"], r["extras"]["megabytes"]],
    ),
)

# docs/install.md's table of what `pip install .` brings, and its extras, from the same results
INSTALL = "docs/install.md"
FIGURES += tuple(
    Figure(rf"\| {name} \| [\d.]+ \| ([\d.]+) \|", WHEEL, lambda r, name=name: [_package(r, name)], 0.05, INSTALL)
    for name in ("llvmlite", "numpy", "numba", "lxml", "deik", "tqdm")
) + (
    Figure(
        r"\*\*Numba's stack\*\* \| \| \*\*([\d.]+)\*\*.*\*\*deik's additions\*\* \| \| \*\*([\d.]+)\*\*.*"
        r"\*\*(\d+) packages\*\* \| \| \*\*([\d.]+)\*\*",
        WHEEL,
        lambda r: [r["numba_stack"]["megabytes"], r["deik_additions"]["megabytes"], r["package_count"], r["megabytes"]],
        (0.05, 0.05, "shown", 0.05),  # within 5 %: a fresh install of a later deik checks them too
        document=INSTALL,
    ),
    Figure(
        r"matplotlib and its dependencies: (\d+) packages and (\d+) MB beside deik's own",
        "benchmarks/results/wheel_install_viz.json",
        lambda r: [r["extras"]["package_count"], r["extras"]["megabytes"]],
        document=INSTALL,
    ),
    Figure(
        r"pycollada \(DAE meshes, ([\d.]+) MB with its dependencies\): (\d+) packages and (\d+) MB beside",
        VIEW,
        lambda r: [
            sum(_package(r["extras"], name) for name in ("pycollada", "python-dateutil", "tzdata")),
            r["extras"]["package_count"],
            r["extras"]["megabytes"],
        ],
        document=INSTALL,
    ),
)

# Numbers beside a command that are not measurements: {pattern: why}. Every number a pattern's
# match covers counts as explained.
SETTINGS = {
    r"the CMU database's 1/0\.45 inch": "the CMU database's length unit (deik.cleanup.units.METRES)",
    r"cases still slide more than 5 mm a frame": "the noise_draws benchmark's count of large slides "
    "(benchmarks/noise_draws.py)",
    r"accelerate past 1\.1 times its own peak in the capture \(within 2 s of that frame\)": "the calm stage's "
    "limit and window (deik.cleanup.dynamics.PEAK_RATIO, PEAK_SECONDS)",
    r"other joint names, 30 fps\) and with one more change .*? the middle frame a T-pose\), three standing still "
    r".*? the body 12 mm under the\s+floor\), six on a game rig's hands and feet .*? none of which the capture "
    r"moves; the get-up and the\s+crawl lay those hands on the floor\), three on a rig that\s+rests lying .*? "
    r"every frame, as an FBX export of a Z-up scene writes it\), "
    r"four captured at 120 fps\s+\(`_120fps`\), five with capture noise at 60 fps or more \(`_120fps_noisy`, and "
    r"`_noisy` for\s+the clips captured at 60 fps\)": "the hard cases' transforms (judging/cases.py)",
    r"bends \(`_toes`, 5 degrees back and forth": "the toes transform (judging/cases.py: TOE_BEND)",
    r"A capture that shakes at 45 fps or more is low-passed before the fix\s+\(a 6 Hz Gaussian": "when and how "
    "deik low-passes a capture (deik.cleanup.noise: WIDEST_FRAME, LOW_PASS)",
    r"the walk, the run and the kick at 120 fps with capture noise": "the retarget hard cases "
    "(benchmarks/retarget_quality.py: 120fps_noisy, from judging/cases.py)",
    r"the kick, the walk\s+and the run at 120 fps with noise meet every target": "the cases named "
    "(judging/cases.py: shaky), their verdicts in the table below",
    r"contact detector, floor at 0 ": "the judge's floor (judging/clips.py)",
    r"on the game rigs with noise at\s+30 fps slide": "the cases named (judging/cases.py: the shared kick and punch "
    "at their 30 fps, `_digits_noisy` and `_toes_noisy`)",
    r"At 30 fps, where nothing is filtered": "the retarget hard cases (benchmarks/retarget_quality.py: "
    "30fps_noisy, judging/cases.py's `_noisy` of the walk and kick at their 30 fps)",
    r"counts as touching up to\s+1 % of the body's span above": "where deik's report counts a point along a bone as "
    "touching (deik.cleanup.bone_points.TIE)",
    r"The targets: sliding at most 1 mm per frame .*? accelerating past 1\.1x its own capture peak": "issue 27's "
    "targets (benchmarks.clip_targets.TARGETS)",
    r"and every one at 50 fps \(`_50fps`": "the pal transform (judging/cases.py)",
    r"with bending toes and at 50 fps, the acceleration": "the transforms of the DeepMimic family's run "
    "(benchmarks/results/clip_probe: --transforms ... toes pal)",
    r"\| case \| sliding mm/frame \| under the floor mm \|.*?\| walk_50fps \|(?: [^|]* \|){5}": "the table of "
    "benchmarks/results/clip_targets.json, checked row for row by tests/benchmarks/test_bench_clip_targets.py",
    r"above the 200 MB we aimed at": "issue 19's target (benchmarks.wheel_install.MAX_MEGABYTES)",
    r"about 10 minutes on 2 cores": "measured by tests/cli/test_readme_claims.py::"
    "test_make_figures_takes_the_time_the_readme_says, against docs/paper-reproduction.md",
    r"Python >= 3\.11": "the Python deik requires (pyproject.toml requires-python)",
    r"the few that take over about 20 s": "the slow marker's definition (pyproject.toml markers)",
    r"Pose frame 12 of a BVH clip": "the command's --frame 12",
    r"to 0\.1 mm and 0\.05 degrees": "the command's --tolerance 0.0001 --angle-tolerance 0.05, which "
    "tests/cli/test_readme.py checks the solve meets",
    r"\(9 numbers, row by row\)": "a 3x3 matrix",
    r"more than 30 degrees from the capture": "the threshold of the joints listed as far from the capture",
    r"eases in and out over 8 frames": "the reach track's ease (deik.cleanup.tracks)",
    r"by more than 5 % of the capture's largest acceleration": "the balance track's acceleration budget",
    r"moving more than 8 % of the body's reach": "the balance track's reach budget",
    r"A 1000-frame clip": "the benchmark's clip length",
    r"10 % longer legs put the feet 8\.7 cm under the floor": "the legs' scale is the example's; the depth is "
    "measured by "
    "tests/cli/test_readme_claims.py::test_longer_legs_sink_as_far_as_the_readme_says_without_a_retarget",
    r"no \+-180 degree wraps": "a half turn: the wrap a joint value must not make between frames",
    r"velocity limit and 1\.5 times the source's largest joint turn": "the step allowance onto a robot "
    "(deik.retargeting.continuity), which benchmarks/retarget_quality.py checks every step against",
    r"\(the bound: 0\.1 statures,": "the wrist bound of benchmarks/retarget_quality.py",
    r"\(exit status 1\)": "the exit status of a folder run with a failed clip",
    r"exit status 2": "the exit status of bad input",
    r"\(exit 3;": "the exit status of an internal error",
    r"exits with 130": "the exit status after Ctrl-C (128 + SIGINT)",
    r"exceeds 80 % of the machine": "the default memory limit (deik.solver.memory)",
    r"over 1 GiB": "the default input size limit (DEIK_MAX_INPUT_BYTES)",
}


def _decimals(text: str) -> int:
    return len(text.split(".")[1]) if "." in text else 0


def values(number: str) -> list[str]:
    """The values a stated number gives: both ends of a range ("7-27"), else itself ("-30")."""
    ends = re.fullmatch(r"(-?[\d,.]+)-([\d,.]+)", number)
    return list(ends.groups()) if ends else [number]


def agrees(text: str, measured: float, tolerance: Tolerance) -> bool:
    """Whether `measured` bears out the stated number `text` (one value of it) within
    `tolerance`: "shown", within one unit of the last digit the README shows (0.62: 0.61 to
    0.63, rounding either way); "at most" / "at least", on that side of it; a fraction, within
    that share of the measurement or one unit of the last digit, whichever is more."""
    value, unit = float(text.replace(",", "")), 10.0 ** -_decimals(text)
    if tolerance == "shown":
        return abs(measured - value) <= unit * (1 + 1e-9)
    if tolerance == "at most":
        return measured <= value
    if tolerance == "at least":
        return measured >= value
    return abs(measured - value) <= max(float(tolerance) * abs(measured), unit * (1 + 1e-9))


def check(figure: Figure, record: dict, text: str | None = None) -> list[str]:
    """What the figure's document (or `text`) states that `record` (figure.measure's input)
    contradicts: one line per number, or a line saying the pattern does not match once; []
    when all agree."""
    found = re.findall(figure.pattern, collapsed((ROOT / figure.document).read_text() if text is None else text))
    if len(found) != 1:
        return [
            f"{figure.document}: {len(found)} matches of {figure.pattern!r} (one expected): reword the figure or "
            "the pattern"
        ]
    groups = found[0] if isinstance(found[0], tuple) else (found[0],)
    tolerances = figure.tolerance if isinstance(figure.tolerance, tuple) else (figure.tolerance,) * len(groups)
    numbers = [(part, tol) for group, tol in zip(groups, tolerances) for part in values(group)]
    measured = figure.measure(record)
    if len(measured) != len(numbers):
        return [f"{figure.pattern!r}: {len(measured)} measured values for {len(numbers)} stated"]
    return [
        f"{figure.document} states {part} where {figure.source} measures {value:.6g} (tolerance: {tol}): "
        f"{figure.pattern!r}"
        for (part, tol), value in zip(numbers, measured)
        if not agrees(part, value, tol)
    ]


def results_record(figure: Figure) -> dict:
    """The JSON file a results figure is measured by."""
    return json.loads((ROOT / figure.source).read_text())


def unexplained(text: str | None = None) -> list[str]:
    """Numbers in the prose beside the README's commands that no FIGURES pattern (in a group) and
    no SETTINGS pattern covers, each with its context."""
    out = []
    for prose in prose_beside_commands(text):
        covered = []
        for figure in FIGURES:
            for m in re.finditer(figure.pattern, prose):
                covered += [m.span(k) for k in range(1, (m.lastindex or 0) + 1)]
        for pattern in SETTINGS:
            covered += [m.span() for m in re.finditer(pattern, prose)]
        for number in numbers_in(prose):
            if not any(a <= number.start() and number.end() <= b for a, b in covered):
                out.append(f"{number.group(0)!r} in '...{prose[max(number.start() - 60, 0) : number.end() + 40]}...'")
    return out


def command_record(figure: Figure, records: list[dict], clone: Path) -> dict:
    """The record figure.measure reads for a README command figure, from the records of
    readme_commands.run_lines run in `clone`: {"stdout", "json": the file the command
    wrote with --json, or None}."""
    (record,) = [r for r in records if r["line"].startswith(figure.source)]
    words = shlex.split(record["line"])
    written = clone / words[words.index("--json") + 1] if "--json" in words else None
    return {"stdout": record.get("stdout", ""), "json": json.loads(written.read_text()) if written else None}
