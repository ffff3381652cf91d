"""The registry of goal kinds: every kind has its row, goal class, oracle function and file
schema; its "polish differentiates" flag agrees with the kernel's Jacobian rows; report units
come from the registry, never from a label."""

import dataclasses

import numpy as np

import deik
from deik import Joint, Site, build_skeleton, translation
from deik.backends import cpu_kernels as cpu
from deik.backends.pack import pack_skeleton, pack_terms
from deik.objectives import kinds, registry
from deik.objectives.goals import Goal
from deik.objectives.registry import KIND_NAMES, KINDS, kind_of
from deik.solver.problem_goals import GOAL_TYPES, ORIENTATION_KEYS
from helpers import every_goal_problem

KIND_CODES = (
    "POSITION",
    "ORIENTATION",
    "AIM",
    "COM",
    "COM_GROUND",
    "SUPPORT_POLYGON",
    "COMFORT_SUM",
    "COMFORT_MAX",
    "LIMITS",
    "OBSTACLE",
    "SELF_COLLISION",
    "FLOOR",
)


def test_every_kind_has_a_row_a_goal_class_an_oracle_and_a_file_schema():
    codes = sorted(getattr(kinds, name) for name in KIND_CODES)
    assert [row.kind for row in KINDS] == codes and len(KIND_NAMES) == len(codes)
    # every kind a problem can compile has its row (the every-goal problem compiles each kind)
    assert set(every_goal_problem().table.kinds.tolist()) == set(codes)
    for row in KINDS:
        assert kind_of(row.kind) is row
        assert issubclass(row.goal, Goal) and row.goal.LABEL, row.name
        assert callable(row.oracle) and row.oracle is getattr(registry, row.name), row.name
        if row.goal is getattr(deik, row.goal.__name__, None):  # a user goal: written in problem files
            cls, required, optional = GOAL_TYPES[row.file_type]
            fields = {f.name for f in dataclasses.fields(cls)} | set(ORIENTATION_KEYS) | {"degrees"}  # its forms
            assert cls is row.goal and set(required) | set(optional) <= fields, row.name
        else:  # the internal joint-limits penalty: no file type
            assert row.kind == kinds.LIMITS and row.file_type is None
    assert set(GOAL_TYPES) == {row.file_type for row in KINDS if row.file_type}


def _all_positive_problem():
    """Every kind of term, each with a positive weight so the polish could take it."""
    problem = every_goal_problem()
    goals = [dataclasses.replace(g, weight=abs(g.weight)) for g in problem.goals]
    return deik.Problem(problem.skeleton, goals, limits="penalty")


def test_polish_flag_agrees_with_the_kernels_jacobian_rows():
    problem = _all_positive_problem()
    sk = problem.skeleton
    poses = sk.reference + np.random.default_rng(5).normal(0.0, 0.1, (3, sk.n_dofs))
    poses = np.clip(poses, sk.lower, sk.upper)
    skel, terms = pack_skeleton(sk, np.float64), pack_terms(problem.table, problem.reference, np.float64)
    index = np.zeros(len(poses), np.int64)
    seen = set()
    for t, kind in enumerate(problem.table.kinds):
        _, jacobian = cpu.residual_rows(poses, index, t, skel, terms)
        differentiated = bool(np.abs(jacobian).max() > 0)
        assert differentiated == kind_of(kind).polished, problem.table.labels[t]
        seen.add(int(kind))
    assert seen == {row.kind for row in KINDS}


def test_units_come_from_the_registry():
    chain = deik.chain(3)  # rotations only
    slider = build_skeleton([Joint("root", None, dofs=translation("XY", -1.0, 1.0))], [Site("end", "root")])
    h = deik.humanoid()  # root translations and joint rotations
    limits = kind_of(kinds.LIMITS)
    assert (limits.unit_for(chain), limits.unit_for(slider), limits.unit_for(h)) == ("rad", "m", "rad+m")
    assert kind_of(kinds.POSITION).unit_for(chain) == "m" and kind_of(kinds.AIM).unit_for(chain) == "rad"
    target = deik.forward_kinematics(chain, np.array([0.3, -0.2, 0.4])).position("tip")
    result = deik.solve(
        deik.Problem(chain, [deik.Position("tip", target, tolerance=1e-3)], limits="penalty"),
        population=16,
        generations=5,
        dtype="float64",
    )
    assert [(g.label, g.kind, g.unit) for g in result.goals] == [
        ("position tip", "position", "m"),
        ("joint limits", "joint_limits", "rad"),
    ]


def test_each_goal_kind_compiles_in_one_method_into_a_row_built_by_keyword():
    """A goal kind defines `row` and nothing else of the compiling (the shared part is
    Goal._row and Goal.target_params), and its row carries its parameters, as Problem reads them."""
    problem = every_goal_problem()
    compiling = {"row", "params", "compile", "target_params", "_row", "reference_pose"}
    for kind in KINDS:
        assert compiling & set(vars(kind.goal)) == {"row"}, kind.name
    for goal, row, t in zip(problem.goals, problem.rows, range(len(problem.goals))):
        again = goal.row(problem.skeleton)
        assert again.kind == row.kind and again.label == row.label == problem.table.labels[t]
        np.testing.assert_array_equal(
            problem.table.params[:, t, : kinds.GAIN],
            np.broadcast_to(again.params[:, : kinds.GAIN], problem.table.params[:, t, : kinds.GAIN].shape),
        )
    for record in (registry.GoalKind, registry.Posed, registry.Term, deik.objectives.table.TermRow):
        assert all(f.kw_only for f in dataclasses.fields(record)), record.__name__
