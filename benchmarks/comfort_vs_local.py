"""Single poses that stay close to their reference: deik against a local solver started there.

    python -m benchmarks.comfort_vs_local [--problems 24] [--quick]

Issue 17 item 6. Each problem is a standing `deik.humanoid()`: both feet planted where the
reference pose has them (heel and toe tip, level 0), both hands at targets made by forward
kinematics of a random pose that keeps the legs and pelvis of the reference and turns the spine,
neck and arms (level 1), and `Comfort` towards the reference on the lowest level (2). The local
solver is what a Jacobian user would run: scipy's bounded trust-region least squares (the
Levenberg-Marquardt family) from the reference pose on the same position goals in tolerances,
which ends near the start because each step is a damped minimum-norm one. Both must meet every
goal; the deviation from the reference is the Comfort measure itself (Eq. 6: sum over DOFs of
|angle - reference|, radians, pelvis translation in metres) and the Euclidean joint distance.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

import deik
from benchmarks import harness
from deik.solver.seeding import poses_around

FEET = ("left_heel", "left_toe_tip", "right_heel", "right_toe_tip")
HANDS = ("left_hand", "right_hand")
TOLERANCE = 0.005  # metres, every position goal
MOVED = ("spine", "chest", "neck", "head", "clavicle", "shoulder", "arm", "elbow", "forearm", "wrist", "hand")


def moving_dofs(skeleton) -> np.ndarray:
    """(D,) bool: the DOFs the random poses turn (spine, neck, arms), not the pelvis or legs."""
    return np.array([any(k in name.split(".")[0] for k in MOVED) for name in skeleton.dof_names])


def make_targets(count: int, seed: int) -> dict:
    """Feet at the reference, hands at FK of `count` random poses (spread 0.4 rad on the upper
    body around the reference, folded into the limits): {name: (count, 3)} and the poses."""
    human = deik.humanoid()
    poses = poses_around(human, human.reference, count + 1, spread=0.4, seed=seed)[1:]
    poses[:, ~moving_dofs(human)] = human.reference[~moving_dofs(human)]
    rest = deik.forward_kinematics(human, human.reference)
    targets = {name: np.repeat(rest.position(name)[None], count, axis=0) for name in FEET}
    for name in HANDS:
        targets[name] = np.stack([deik.forward_kinematics(human, q).position(name) for q in poses])
    return {"skeleton": human, "targets": targets, "poses": poses}


def deik_problem(case: dict) -> deik.Problem:
    """Feet on level 0, hands on level 1, Comfort towards the reference on level 2."""
    goals = [deik.Position(n, case["targets"][n], tolerance=TOLERANCE) for n in FEET]
    goals += [deik.Position(n, case["targets"][n], tolerance=TOLERANCE, level=1) for n in HANDS]
    return deik.Problem(case["skeleton"], goals + [deik.Comfort(level=2)])


def position_errors(skeleton, q: np.ndarray, targets: dict, b: int) -> np.ndarray:
    """(goals,) distances (m) of every foot and hand point of pose q from problem b's targets."""
    kin = deik.forward_kinematics(skeleton, q)
    return np.array([np.linalg.norm(kin.position(n) - targets[n][b]) for n in FEET + HANDS])


def local_solve(skeleton, targets: dict, b: int) -> np.ndarray:
    """Problem b by bounded trust-region least squares from the reference pose: (D,) radians."""

    def residuals(q):
        kin = deik.forward_kinematics(skeleton, q)
        return np.concatenate([(kin.position(n) - targets[n][b]) / TOLERANCE for n in FEET + HANDS])

    fit = least_squares(residuals, skeleton.reference, bounds=(skeleton.lower, skeleton.upper), xtol=1e-12)
    return fit.x


def deviations(skeleton, poses: np.ndarray) -> dict:
    """Comfort sum (Eq. 6) and Euclidean distance of (B, D) poses from the reference."""
    delta = poses - skeleton.reference
    return {"comfort_sum": np.abs(delta).sum(axis=-1), "euclidean": np.linalg.norm(delta, axis=-1)}


def compare(count: int, seed: int, settings: dict) -> dict:
    """Solve `count` problems both ways; per problem: goals met and deviations, both solvers."""
    case = make_targets(count, seed)
    human, targets = case["skeleton"], case["targets"]
    result = deik.solve(deik_problem(case), seed=seed, **settings)
    local = np.stack([local_solve(human, targets, b) for b in range(count)])
    rows = {}
    for name, poses in (("deik", np.asarray(result.angles, np.float64)), ("local", local)):
        errors = np.stack([position_errors(human, poses[b], targets, b) for b in range(count)])
        rows[name] = {
            "met": (errors <= TOLERANCE * (1 + 1e-6)).all(axis=1).tolist(),
            "max_error_m": errors.max(axis=1).tolist(),
            **{k: v.tolist() for k, v in deviations(human, poses).items()},
        }
    rows["truth"] = {k: v.tolist() for k, v in deviations(human, case["poses"]).items()}
    rows["deik_seconds"] = result.wall_time
    return rows


def main(argv=None) -> dict:
    """Run the comparison; write results/comfort_vs_local.{json,md,png}."""
    p = harness.parser(__doc__)
    p.add_argument("--problems", type=int, help="humanoid problems (default 24; 4 with --quick)")
    run = harness.start("comfort_vs_local", p, argv, {"problems": 24}, {"problems": 4})
    args = run.args
    settings = {"device": args.device, "dtype": "float64"}
    rows = compare(args.problems, args.seed, settings)
    both = np.array(rows["deik"]["met"]) & np.array(rows["local"]["met"])
    d, c = np.array(rows["deik"]["comfort_sum"]), np.array(rows["local"]["comfort_sum"])
    no_larger = float(np.mean(d[both] <= c[both] * (1 + 1e-3))) if both.any() else 0.0
    run.target("share of problems both solvers solve", 1.0, float(both.mean()), "")
    run.target("share where deik's deviation <= the local solver's", 1.0, no_larger, "", not args.quick)
    summary = {
        "both_met": int(both.sum()),
        "deik_no_larger_share": no_larger,
        "deik_mean_comfort_sum": float(d[both].mean()) if both.any() else None,
        "local_mean_comfort_sum": float(c[both].mean()) if both.any() else None,
    }
    fig, axes = harness.figure()
    axes[0, 0].scatter(c[both], d[both], s=12)
    top = max(float(c.max()), float(d.max())) * 1.05
    axes[0, 0].plot([0, top], [0, top], "k--", lw=0.8, label="equal")
    xlabel, ylabel = "local solver: sum |q - reference| (rad, m)", "deik: sum |q - reference| (rad, m)"
    harness.style_axes(axes[0, 0], xlabel, ylabel, "deviation from the reference, goals met", xlog=False, ylog=False)
    cells = [[b, f"{c[b]:.3f}", f"{d[b]:.3f}", rows["deik"]["met"][b]] for b in range(args.problems)]
    body = harness.md_table(["problem", "local sum", "deik sum", "deik met"], cells)
    result = {
        "problems": args.problems,
        "settings": settings,
        "tolerance_m": TOLERANCE,
        "rows": rows,
        "summary": summary,
    }
    return run.finish(result, body, fig, {k: v for k, v in summary.items() if v is not None})


if __name__ == "__main__":
    main()
