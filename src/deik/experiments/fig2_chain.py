"""Fig. 2: a planar chain reaching one target; plain, straight near its start, straight near its end.

The scenarios are the demo's (`deik.experiments.demo.chain_scenarios`): the tip within 1 % of the reach on
the top priority level, and for (b), (c) a comfort goal on the level below whose per-joint
weights ramp down from the root ("start") or up towards the tip ("end"); the reference pose is
straight (all angles 0). Each seed draws its own target (the tip of a random in-limit pose)
and its own DE stream. We measure how bent each third of the chain is: the mean |angle|
(radians) of its joints.
"""

from __future__ import annotations

import os

import numpy as np

from deik.experiments.demo import chain_scenarios
from deik.experiments.shared import (
    DE_ONLY,
    Section,
    command,
    describe,
    markdown_table,
    pose_panels,
    save_figure,
    seed_list,
    write_csv,
)
from deik.solver.solve import solve
from deik.viz.plot import require_matplotlib

NAME = "fig2"
VARIANTS = ("reach only", "straight near start", "straight near end")


def sizes(quick: bool) -> dict:
    """Links, seeds and generation budget of the full or quick run."""
    if quick:
        return {"links": 8, "seeds": seed_list(True, 0, 2), "overrides": {"generations": 150, "patience": 40}}
    return {"links": 20, "seeds": seed_list(False, 20, 0), "overrides": {}}


def solve_variants(n_links: int, seed: int, overrides: dict) -> list[tuple]:
    """[(scenario, Result)] for Figs. 2a-2c on deik.chain(n_links), target and DE stream from
    `seed`; angles of each Result are (n_links,) radians."""
    out = []
    for scenario in chain_scenarios(n_links, seed):
        settings = {**scenario.settings, **DE_ONLY, "seed": seed, **overrides}
        out.append((scenario, solve(scenario.problem, **settings)))
    return out


def thirds(angles: np.ndarray) -> tuple[float, float]:
    """Mean |angle| (rad) of the first and of the last third of a chain's joints, angles (D,)."""
    k = max(1, len(angles) // 3)
    a = np.abs(np.asarray(angles, dtype=np.float64))
    return float(a[:k].mean()), float(a[-k:].mean())


def run(out_dir: str, quick: bool = False, device: str = "cpu") -> Section:
    """Solve the three variants for every seed; write fig2.{csv,png}. CSV: one row per
    (seed, variant) with the tip error (% of reach), met, generations, the thirds' mean
    |angle| and every |angle_j| (rad). `device` is unused (CPU)."""
    cfg = sizes(quick)
    n = cfg["links"]
    rows, first = [], None
    for seed in cfg["seeds"]:
        solved = solve_variants(n, seed, cfg["overrides"])
        first = first or solved
        for variant, (scenario, result) in zip(VARIANTS, solved):
            tip = result.goals[0]
            start, end = thirds(result.angles)
            row = {
                "seed": seed,
                "variant": variant,
                "links": n,
                "tip_error_percent_of_reach": 100 * float(tip.error) / scenario.reach,
                "tip_met": bool(tip.met),
                "generations": int(result.generations),
                "mean_abs_angle_first_third_rad": start,
                "mean_abs_angle_last_third_rad": end,
            }
            row.update({f"abs_angle_j{j:02d}": float(abs(a)) for j, a in enumerate(result.angles)})
            rows.append(row)
    write_csv(os.path.join(out_dir, f"{NAME}.csv"), rows)
    _plot(out_dir, first, rows, n)

    table, stats = [], {}
    for variant in VARIANTS:
        sel = [r for r in rows if r["variant"] == variant]
        stats[variant] = {
            key: np.median([r[key] for r in sel])
            for key in ("mean_abs_angle_first_third_rad", "mean_abs_angle_last_third_rad")
        }
        table.append(
            [
                variant,
                len(sel),
                sum(not r["tip_met"] for r in sel),
                describe([r["tip_error_percent_of_reach"] for r in sel]),
                describe([r["mean_abs_angle_first_third_rad"] for r in sel]),
                describe([r["mean_abs_angle_last_third_rad"] for r in sel]),
                describe([r["generations"] for r in sel], 4),
            ]
        )
    s, e = stats[VARIANTS[1]], stats[VARIANTS[2]]
    a = stats[VARIANTS[0]]
    headline = (
        f"{n}-link chain, {len(cfg['seeds'])} seeds: the tip met 1 % of reach in "
        f"{sum(r['tip_met'] for r in rows)}/{len(rows)} runs; median mean absolute angle of the "
        f"first third {a['mean_abs_angle_first_third_rad']:.2f} rad (reach only) -> "
        f"{s['mean_abs_angle_first_third_rad']:.2f} (straight start), of the last third "
        f"{a['mean_abs_angle_last_third_rad']:.2f} -> {e['mean_abs_angle_last_third_rad']:.2f} (straight end)."
    )
    measurement = markdown_table(
        [
            "variant",
            "seeds",
            "tip missed",
            "tip error, % reach",
            "first third mean abs angle, rad",
            "last third mean abs angle, rad",
            "generations",
        ],
        table,
    ) + (
        "\n\nCells are median [quartiles] over seeds. The pictures show seed 0; the lower panel the "
        "median |angle| per joint."
    )
    return Section(
        name=NAME,
        title="Fig. 2: one target, three secondary objectives",
        claim="Pictures only, no numbers: a serial chain reaches a target with (a) the end-effector "
        "distance alone, (b) plus a secondary bias keeping the links near the start of the chain "
        "straight, (c) the same near the end.",
        headline=headline,
        measurement=measurement,
        differences="The paper folds the straightness term into one weighted sum; we put it on a lower strict "
        "priority level (the reach never pays for straightness) and use a linear per-joint ramp "
        '(`Comfort(joint_weights="start"/"end")`). Settings are the demo\'s (population 256, '
        "best/1/bin), not rand/1/bin; the paper gives no settings, chain length or target for this "
        "figure, so we quantify the shape over many random targets instead of one picture. The "
        "summed |angle| (Eq. 6) is an L1 penalty, so the optimum bends few joints sharply, above all "
        'the joint whose ramp weight is zero (the last for "start", the root for "end"), where '
        "the paper's pictures bend smoothly.",
        command=command(NAME, quick),
    )


def _plot(out_dir: str, first: list[tuple], rows: list[dict], n: int) -> None:
    plt = require_matplotlib()
    figure = plt.figure(figsize=(13, 8.5))
    grid = figure.add_gridspec(2, 3, height_ratios=(1.5, 1))
    panels = [(sc.problem, res, f"({'abc'[k]}) {VARIANTS[k]}") for k, (sc, res) in enumerate(first)]
    pose_panels([figure.add_subplot(grid[0, k]) for k in range(3)], panels)
    ax = figure.add_subplot(grid[1, :])
    joints = np.arange(n)
    for variant in VARIANTS:
        a = np.array([[r[f"abs_angle_j{j:02d}"] for j in joints] for r in rows if r["variant"] == variant])
        q1, med, q3 = np.percentile(a, [25, 50, 75], axis=0)
        ax.plot(joints, med, "o-", label=variant)
        ax.fill_between(joints, q1, q3, alpha=0.2)
    ax.set_xticks(joints)
    ax.set_xlabel("joint (0 = root)")
    ax.set_ylabel("|angle|, rad (median, quartiles)")
    ax.grid(alpha=0.3)
    ax.legend()
    figure.suptitle(f"Fig. 2: {n}-link chain, seed 0 poses; per-joint bend over {len(rows) // 3} seeds")
    figure.tight_layout()
    save_figure(figure, os.path.join(out_dir, f"{NAME}.png"))
