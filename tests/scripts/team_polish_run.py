"""Strict targets from forward kinematics of random in-limit poses, polished by the first polish
on the device and path named in argv; print, as JSON, the answers, each goal's largest error by
NumPy's forward kinematics of the answers, and which first-polish kernel ran.

    PYTHONPATH=src python tests/scripts/team_polish_run.py CASE PATH [DTYPE]

CASE "arm": a 7-DOF arm (the Franka Panda's kinematics: joint origins, axes and limits from its
URDF), 6-D targets (1e-5 m, 1e-4 rad), 18 problems, six residual rows for seven DOFs (the
m x m dual step); the GPU is told it holds 128 threads at once, so one block of 16 teams takes
the problems in two groups, the second with 14 teams idle. "chain": a 24-DOF chain (12 ball
joints), five problems: tip targets at 1e-5 m, on problem 0 an orientation of link 5 too, on
problem 1 the positions of links 1-11 too (36 rows for 24 DOFs: the normal equations, three
DOFs per lane), the centre of mass on problems 1 and 2 and its ground projection on problems 1
and 3 (every Jacobian function's columns split across the lanes, in the dual step and the
normal equations). "wide": a 34-DOF chain's tip targets, more DOFs than a team's shared slab
holds (the thread-per-problem kernel runs). "turns": the arm with every joint turning all round
(limits +-pi), 6-D targets whose every joint lies within 0.25 rad of +-pi, each started 0.3 rad
across +-pi from it (the polish wraps round: stopped at the limit it stalls). Every other target
is the forward kinematics of a random in-limit pose; the start is that pose moved by up to 0.3
rad a DOF. PATH: "team" (the GPU's
team per problem where it can), "thread" (a thread per problem) or "cpu". Used by
tests/backends/test_cuda.py in subprocesses (the CUDA simulator needs its own process).
"""

import json
import math
import sys

import numpy as np

import deik
from deik import Joint, Site, hinge

STRICT = (1e-5, 1e-4)  # metres, radians


def arm(all_round=False):
    """A 7-revolute arm with the Franka Panda's joint origins, rest rotations, z hinges and
    limits (every joint +-pi with `all_round`)."""
    half = math.pi / 2

    def rx(angle):
        c, s = math.cos(angle), math.sin(angle)
        return ((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c))

    links = [  # (offset from the parent joint, rest rotation about x, lower, upper)
        ((0.0, 0.0, 0.333), 0.0, -2.8973, 2.8973),
        ((0.0, 0.0, 0.0), -half, -1.7628, 1.7628),
        ((0.0, -0.316, 0.0), half, -2.8973, 2.8973),
        ((0.0825, 0.0, 0.0), half, -3.0718, -0.0698),
        ((-0.0825, 0.384, 0.0), -half, -2.8973, 2.8973),
        ((0.0, 0.0, 0.0), half, -0.0175, 3.7525),
        ((0.088, 0.0, 0.0), half, -2.8973, 2.8973),
    ]
    joints = [Joint("base", None, mass=4.0)]
    for k, (offset, angle, lower, upper) in enumerate(links):
        lower, upper = (-math.pi, math.pi) if all_round else (lower, upper)
        parent = joints[-1].name
        joints.append(
            Joint(f"joint{k + 1}", parent, offset, hinge((0, 0, 1), lower, upper), mass=1.0, rotation=rx(angle))
        )
    sites = [Site("flange", "joint7", (0.0, 0.0, 0.107))]
    return deik.build_skeleton(joints, sites=sites, up=(0.0, 0.0, 1.0), name="arm7")


def _kind_and_target(goal, kin):
    """(kind, frame, targets as lists) of one of the cases' goals, for the independent check."""
    if isinstance(goal, deik.Orientation):
        return "orientation", goal.frame, kin.rotation(goal.frame).tolist()
    if isinstance(goal, (deik.CentreOfMass, deik.ComOverSupport)):
        kind = "position com" if isinstance(goal, deik.CentreOfMass) else "position com ground"
        return kind, None, kin.p_world_com.tolist()
    return "position", goal.frame, kin.position(goal.frame).tolist()


def problem(case):
    """(skeleton, Problem, start poses, goals: [(kind, frame, targets, active)] as lists)."""
    if case in ("arm", "turns"):
        skeleton, end, n = arm(case == "turns"), "flange", 18
    else:
        skeleton, end, n = deik.chain(12 if case == "chain" else 17, dims=3, lower=-1.0, upper=1.0), "tip", 5
    rng = np.random.default_rng(11)
    poses = rng.uniform(skeleton.lower, skeleton.upper, (n, skeleton.n_dofs))
    if case == "turns":  # each joint near +-pi, its start 0.3 rad on across it
        poses = rng.choice([-1.0, 1.0], poses.shape) * (math.pi - rng.uniform(0.0, 0.25, poses.shape))
    kin = deik.forward_kinematics(skeleton, poses)
    goals = [deik.Position(end, kin.position(end), tolerance=STRICT[0])]
    if case in ("arm", "turns"):
        goals.append(deik.Orientation(end, kin.rotation(end), tolerance=STRICT[1]))
    elif case == "chain":
        first, second = np.arange(n) == 0, np.arange(n) == 1
        goals.append(deik.Orientation("link5", kin.rotation("link5"), tolerance=STRICT[1], active=first))
        for k in range(1, 12):
            goals.append(deik.Position(f"link{k}", kin.position(f"link{k}"), tolerance=STRICT[0], active=second))
        goals.append(deik.CentreOfMass(kin.p_world_com, tolerance=STRICT[0], active=np.isin(np.arange(n), (1, 2))))
        goals.append(deik.ComOverSupport(kin.p_world_com, tolerance=STRICT[0], active=np.isin(np.arange(n), (1, 3))))
    start = poses + np.random.default_rng(12).uniform(-0.3, 0.3, poses.shape)  # near each target's pose
    if case == "turns":
        start = np.angle(np.exp(1j * (poses + 0.3 * np.sign(poses))))
    listed = [(*_kind_and_target(goal, kin), (np.ones(n, bool) if goal.active is None else goal.active).tolist())
              for goal in goals]  # fmt: skip
    return skeleton, deik.Problem(skeleton, goals), np.clip(start, skeleton.lower, skeleton.upper), listed


case, path = sys.argv[1], sys.argv[2]
dtype = sys.argv[3] if len(sys.argv) > 3 else "float64"
skeleton, prob, start, goals = problem(case)
settings = deik.Settings(population=4, dtype=dtype, device="cpu" if path == "cpu" else "gpu", polish=60)
engine = deik.Engine(prob, settings)
if path != "cpu":
    engine.backend.cooperative_polish = path == "team"
    if case in ("arm", "turns"):
        engine.backend._resident_threads = 128
state = engine.start(0, initial=start[:, None, :])
# the team's scratch pool exists once first_polish_team has run (CudaBackend._team_geometry)
ran = "cpu" if path == "cpu" else ("first_polish_team" if engine.backend.team_pool is not None else "first_polish")
best = state.best
poses = state.pop[np.arange(len(best)), best]
kin = deik.forward_kinematics(skeleton, poses)  # NumPy's forward kinematics, not the kernels'
errors = {}  # per goal, the largest error over the problems it is active in
for kind, frame, targets, active in goals:
    if kind.startswith("position"):
        offset = (kin.p_world_com if frame is None else kin.position(frame)) - np.array(targets)
        if kind.endswith("ground"):  # the horizontal distance
            offset -= np.outer(offset @ skeleton.up, skeleton.up)
        error = np.linalg.norm(offset, axis=-1)
    else:
        relative = np.einsum("bij,bkj->bik", kin.rotation(frame), np.array(targets))
        error = np.arccos(np.clip((np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0))
    errors[f"{kind} {frame or ''}"] = float(error[np.array(active)].max())
print(
    json.dumps(
        {
            "dofs": skeleton.n_dofs,
            "ran": ran,
            "converged": state.converged.tolist(),
            "generations": state.generations.tolist(),
            "pose": poses.tolist(),
            "raw": state.raw[np.arange(len(best)), best].tolist(),
            "errors": errors,
            "inside_limits": bool(((poses >= skeleton.lower) & (poses <= skeleton.upper)).all()),
        }
    )
)
