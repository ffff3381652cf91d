"""The paper's demonstration scenarios, solved, tabulated and drawn (`deik demo --out DIR`).

(a) a 20-link planar chain reaches the tip position of a random pose inside its limits
(Fig. 2a); (b), (c) the same reach with comfort keeping the chain straight near its start or
its end (Figs. 2b, 2c); (d) the humanoid reaches forward and up with its left hand while its
right foot stays planted and its centre of mass stays over that foot (Figs. 4, 5).

Reaches and balance are on the top priority levels, so comfort is never bought with them.
Each goal's tolerance is the bound the demo promises (chain tip within 1 % of the reach;
humanoid hand within 1 cm, centre of mass within 2 cm horizontally, foot sites within 5 mm),
and a scenario passes when the Result reports every toleranced goal met.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from deik.console import progress_bar
from deik.io.atomic import all_or_nothing, write_json_atomically
from deik.model.builders import chain
from deik.model.humanoid import humanoid
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.goals import Comfort, ComOverSupport, Position
from deik.objectives.registry import LENGTH
from deik.solver.problem import Problem
from deik.solver.result import Result
from deik.solver.solve import solve
from deik.viz.marks import length_unit
from deik.viz.plot import plot_result
from deik.viz.text import format_table, shown

CHAIN_SETTINGS = {"population": 256, "strategy": "best/1/bin", "seed": 0}
HUMANOID_SETTINGS = {"population": 256, "generations": 1500, "seed": 1}
CHAIN_BOUND = 0.01  # of the chain's reach
FOOT_BOUND, COM_BOUND, HAND_BOUND = 0.005, 0.02, 0.01  # metres
HAND_OFFSET = 0.25  # metres forward and the same up from the rest hand: about 35 cm away
SUPPORT_SITES = ("right_heel", "right_toe_inner", "right_toe_outer")


@dataclass(frozen=True)
class Scenario:
    """One demo problem: `key` names its PNG; `reach` (length units) adds a % of reach
    column; `initial` poses (n, D) seed the population (None: all random)."""

    key: str
    title: str
    problem: Problem
    settings: dict
    reach: float | None = None
    initial: np.ndarray | None = None


def chain_target(skeleton: Skeleton, seed: int) -> np.ndarray:
    """Tip position (3,) of a pose drawn uniformly inside the joint limits."""
    pose = np.random.default_rng(seed).uniform(skeleton.lower, skeleton.upper)
    return forward_kinematics(skeleton, pose).position("tip")


def chain_scenarios(n_links: int = 20, seed: int = 0) -> list[Scenario]:
    """Figs. 2a-2c on deik.chain(n_links): plain reach, then comfort "start" and "end"."""
    skeleton = chain(n_links)
    reach = Position("tip", chain_target(skeleton, seed), tolerance=CHAIN_BOUND * skeleton.reach)
    variants = [
        ("a_chain_reach", "reach", []),
        ("b_chain_straight_start", "reach, straight near the start", [Comfort(joint_weights="start", level=1)]),
        ("c_chain_straight_end", "reach, straight near the end", [Comfort(joint_weights="end", level=1)]),
    ]
    return [
        Scenario(
            key, f"{n_links}-link chain: {title}", Problem(skeleton, [reach] + extra), CHAIN_SETTINGS, skeleton.reach
        )
        for key, title, extra in variants
    ]


def humanoid_scenario() -> Scenario:
    """Figs. 4, 5: left hand forward and up, right foot planted, balance over the right foot;
    the search starts from the rest pose (one member of the first population), as an animator
    would from the current pose, which keeps the comfort level's answer natural."""
    skeleton = humanoid()
    rest = forward_kinematics(skeleton, skeleton.reference)
    forward = np.array([0.0, 0.0, 1.0])  # the humanoid faces +Z
    hand = rest.position("left_hand") + HAND_OFFSET * (forward + skeleton.up)
    support = np.mean([rest.position(site) for site in SUPPORT_SITES], axis=0)
    goals = [
        Position("right_heel", rest.position("right_heel"), tolerance=FOOT_BOUND, level=0),
        Position("right_toe_tip", rest.position("right_toe_tip"), tolerance=FOOT_BOUND, level=0),
        ComOverSupport(support, tolerance=COM_BOUND, level=0),
        Position("left_hand", hand, tolerance=HAND_BOUND, level=1),
        Comfort(level=2),
    ]
    return Scenario(
        "d_humanoid_reach",
        "humanoid: left-hand reach on the right foot",
        Problem(skeleton, goals),
        HUMANOID_SETTINGS,
        initial=skeleton.reference[None],
    )


def scenario_rows(scenario: Scenario, result: Result) -> list[dict]:
    """One row per goal: error in its unit (and % of reach for chains), its tolerance and
    whether the Result reports it met (None for goals without a tolerance), run facts;
    "passed" when every toleranced goal is met."""
    bounded = [report for report in result.goals if report.tolerance >= 0]
    passed = all(bool(report.met) for report in bounded)
    rows = []
    for report in result.goals:
        error, label = float(report.error), report.label
        percent = 100 * error / scenario.reach if scenario.reach and report.unit == LENGTH else None
        bound = report.tolerance if report.tolerance >= 0 else None
        rows.append(
            {
                "scenario": scenario.key,
                "goal": label,
                "error": error,
                "unit": report.unit,
                "length_unit": length_unit(result.skeleton)[0],
                "percent_of_reach": percent,
                "bound": bound,
                "met": None if bound is None else bool(report.met),
                "generations": int(result.generations),
                "time_s": result.wall_time,
                "passed": passed,
            }
        )
    return rows


def _print_table(rows: list[dict]) -> None:
    cells, previous = [], None
    for row in rows:
        first = row["scenario"] != previous
        previous = row["scenario"]
        cells.append(
            [
                row["scenario"] if first else "",
                row["goal"],
                shown(row["error"], row["unit"], row["length_unit"]),
                "" if row["percent_of_reach"] is None else f"{row['percent_of_reach']:.3f} %",
                "-" if row["bound"] is None else shown(row["bound"], row["unit"], row["length_unit"]),
                {None: "-", True: "yes", False: "NO"}[row["met"]],
                row["generations"] if first else "",
                f"{row['time_s']:.2f} s" if first else "",
            ]
        )
    print(format_table(["scenario", "goal", "error", "% reach", "bound", "met", "generations", "time"], cells))


def _has_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def demo(out_dir: str, scenarios: list[Scenario] | None = None, progress: bool | None = False) -> dict:
    """Solve `scenarios` (default: the paper's four), write one PNG each (with matplotlib)
    and demo.json into `out_dir` (created if missing); a bar over the scenarios with
    `progress` (as deik.console.progress_bar's `show`). Returns demo.json's record:
    {"scenarios": [{"key", "title", "image", "settings", "passed", "result"}], "rows": one per
    goal (its error, bound, "met" and the scenario's "passed"), "total_time_s"}."""
    scenarios = chain_scenarios() + [humanoid_scenario()] if scenarios is None else scenarios
    os.makedirs(out_dir, exist_ok=True)
    start = time.perf_counter()
    rows, summary = [], []
    pictures = _has_matplotlib()  # without it: the table and demo.json only
    # every picture and demo.json appear together at the end, or none (Ctrl-C: nothing is written)
    with all_or_nothing(), progress_bar(len(scenarios), "deik demo", "scenario", progress) as bar:
        for scenario in scenarios:
            bar.set_postfix_str(scenario.key)
            result = solve(scenario.problem, initial=scenario.initial, **scenario.settings)
            bar.update()
            image = f"{scenario.key}.png" if pictures else None
            if pictures:
                plot_result(scenario.problem, result, os.path.join(out_dir, image), title=scenario.title)
            rows += scenario_rows(scenario, result)
            summary.append(
                {
                    "key": scenario.key,
                    "title": scenario.title,
                    "image": image,
                    "settings": scenario.settings,
                    "passed": rows[-1]["passed"],
                    "result": result.to_dict(),
                }
            )
        document = {"scenarios": summary, "rows": rows, "total_time_s": time.perf_counter() - start}
        write_json_atomically(os.path.join(out_dir, "demo.json"), document)
    return document


def run_demo(out_dir: str, scenarios: list[Scenario] | None = None, show: bool | None = None) -> list[dict]:
    """`deik demo`: demo() with a bar (`show`), then the table and the verdict printed.
    Returns the rows; a row's "passed" is False when its scenario missed one of its goals' tolerances."""
    document = demo(out_dir, scenarios, show)
    _print_table(document["rows"])
    missed = [s["key"] for s in document["scenarios"] if not s["passed"]]
    verdict = f"MISSED: {', '.join(missed)}" if missed else "every scenario met its targets"
    pictures = _has_matplotlib()
    written = "pictures and demo.json" if pictures else 'demo.json (no pictures: pip install "deik[viz]")'
    print(f"\n{verdict}; {document['total_time_s']:.1f} s in all; {written} in {out_dir}")
    return document["rows"]
