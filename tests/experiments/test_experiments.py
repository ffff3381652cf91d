"""The paper-reproduction experiments (deik.experiments): every --quick form, run once, checked
for its files and for the behaviour each figure is about. No assertion depends on timings."""

import csv
import math

import numpy as np
import pytest

from deik.experiments import runner
from deik.experiments.fig7_selection import SequentialSerialDE
from deik.experiments.serial_numpy import SerialDE
from deik.experiments.shared import quantile, spread
from deik.experiments.timing import gpu_status, make_problem

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
NAMES = list(runner.EXPERIMENTS)


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """`all --quick` once for the module, with --doc; returns (out folder, doc path)."""
    root = tmp_path_factory.mktemp("experiments")
    out, doc = root / "out", root / "docs" / "paper.md"
    doc.parent.mkdir()
    assert runner.main(["all", "--quick", "--out", str(out), "--doc", str(doc)]) == 0
    return out, doc


def rows(out, name):
    with open(out / f"{name}.csv", newline="") as file:
        return list(csv.DictReader(file))


def median(values):
    return float(np.median([float(v) for v in values]))


@pytest.mark.slow
def test_every_experiment_writes_png_csv_and_section(quick_run):
    out, doc = quick_run
    report = (out / "report.md").read_text()
    for name in NAMES:
        assert (out / f"{name}.png").read_bytes()[:8] == PNG_MAGIC
        assert (doc.parent / "figures" / f"{name}.png").read_bytes()[:8] == PNG_MAGIC
        section = (out / f"{name}.md").read_text()
        assert section.startswith("## Fig.") and "**Paper.**" in section and "**Ours.**" in section
        assert f"python -m deik.experiments {name} --quick --out DIR" in section
        assert section in report
        assert len(rows(out, name)) > 0
    text = doc.read_text()
    assert "(figures/fig3.png)" in text and "## Claims and measurements side by side" in text
    assert not list(out.glob(".deik-*"))  # atomic writes leave no temporary file or journal
    if not gpu_status()[0]:
        assert "GPU column pending" in (out / "fig8.md").read_text()
        assert "GPU column pending" in (out / "fig9.md").read_text()


@pytest.mark.slow
def test_fig2_comfort_ramps_straighten_their_end_of_the_chain(quick_run):
    data = rows(quick_run[0], "fig2")
    assert len(data) == 2 * 3 and all(r["tip_met"] == "True" for r in data)
    by = {v: [r for r in data if r["variant"] == v] for v in ("reach only", "straight near start", "straight near end")}
    first = {v: median(r["mean_abs_angle_first_third_rad"] for r in sel) for v, sel in by.items()}
    last = {v: median(r["mean_abs_angle_last_third_rad"] for r in sel) for v, sel in by.items()}
    assert first["straight near start"] < first["reach only"]
    assert last["straight near end"] < 0.25 * last["reach only"]
    assert all(float(r["tip_error_percent_of_reach"]) <= 1.0 for r in data)


@pytest.mark.slow
def test_fig3_bigger_population_needs_no_more_generations(quick_run):
    data = rows(quick_run[0], "fig3")
    assert len(data) == 2 * 2 * 2 * 8 + 1 * 2 * 2 * 4
    assert {"targets", "strategy", "links", "population", "seed", "generations", "converged"} <= set(data[0])
    for r in data:
        generations = float(r["generations"])
        assert (r["converged"] == "True") == math.isfinite(generations)
        assert generations >= 0 and math.isfinite(float(r["tip_error_percent_of_reach"]))
        if r["converged"] == "True":
            assert float(r["tip_error_percent_of_reach"]) <= 1.0 + 1e-6
    assert sum(r["converged"] == "True" for r in data) >= 0.9 * len(data)
    cells = {(r["targets"], r["strategy"], r["links"]) for r in data}
    for cell in cells:
        gens = {
            p: [
                float(r["generations"])
                for r in data
                if (r["targets"], r["strategy"], r["links"]) == cell and r["population"] == p
            ]
            for p in ("10", "100")
        }
        assert spread(gens["100"])["median"] <= 2 * spread(gens["10"])["median"], cell


@pytest.mark.slow
def test_fig4_com_first_keeps_balance_and_equal_weights_do_not(quick_run):
    data = rows(quick_run[0], "fig4")
    assert len(data) == 3 * 2
    com = {
        v: [float(r["com_over_support_error"]) for r in data if r["variant"] == v]
        for v in ("equal weights", "COM first (strict levels)")
    }
    assert max(com["COM first (strict levels)"]) <= 0.02 + 1e-6
    # equal priority reaches further than COM first. (Whether it also loses balance is the full
    # run's finding, 32 seeds in docs/paper-reproduction.md: at the quick run's population 64 and
    # 150 generations, equal weights end balanced in about 2 of 5 batch members with either
    # random stream, so two members cannot show it.)
    hand = {
        v: [float(r["position_left_hand_error"]) for r in data if r["variant"] == v]
        for v in ("equal weights", "COM first (strict levels)")
    }
    assert min(hand["equal weights"]) < min(hand["COM first (strict levels)"])


@pytest.mark.slow
def test_fig5_comfort_level_keeps_the_pose_closer_to_rest(quick_run):
    data = rows(quick_run[0], "fig5")
    three = [r for r in data if r["variant"].startswith("three")]
    two = [r for r in data if r["variant"].startswith("two")]
    assert len(three) == len(two) == 2 and all(r["all_toleranced_met"] == "True" for r in three)
    assert median(r["comfort_sum_rad"] for r in three) < median(r["comfort_sum_rad"] for r in two)


@pytest.mark.slow
def test_fig6_curves_are_elitist_and_the_sum_beats_the_max(quick_run):
    data = rows(quick_run[0], "fig6")
    assert len(data) == 2 * 2 * 4 * 61
    for strategy in {r["strategy"] for r in data}:
        for mode, column in (("sum", "mean_abs_error_rad"), ("max", "max_abs_error_rad")):
            for seed in range(4):
                curve = [
                    float(r[column])
                    for r in data
                    if (r["strategy"], r["comfort"], r["seed"]) == (strategy, mode, str(seed))
                ]
                assert len(curve) == 61 and np.isfinite(curve).all()
                assert np.all(np.diff(curve) <= 1e-5)  # the optimised yardstick never gets worse
    final = {
        m: median(
            r["mean_abs_error_rad"]
            for r in data
            if r["comfort"] == m and r["generation"] == "60" and r["strategy"].startswith("rand")
        )
        for m in ("sum", "max")
    }
    assert final["sum"] < final["max"]


@pytest.mark.slow
def test_fig7_both_selections_improve_fitness(quick_run):
    data = rows(quick_run[0], "fig7")
    assert len(data) == 2 * 2 * 13
    for selection in ("random", "sequential"):
        for seed in ("0", "1"):
            sel = [r for r in data if (r["selection"], r["seed"]) == (selection, seed)]
            best = [float(r["best_fitness"]) for r in sel]
            mean = [float(r["mean_fitness"]) for r in sel]
            assert np.all(np.diff(best) <= 0) and mean[-1] < 0.8 * mean[0]


@pytest.mark.slow
def test_fig8_fig9_timings_are_complete_and_finite(quick_run):
    devices = {"cpu", "gpu"} if gpu_status()[0] else {"cpu"}
    data = rows(quick_run[0], "fig8")
    assert {r["device"] for r in data} == devices and len(data) == len(devices) * 2 * 2
    assert all(float(r["seconds"]) > 0 for r in data)
    data = rows(quick_run[0], "fig9")
    assert len(data) == 2 * (1 + 2 * (2 + ("gpu" in devices)))
    assert all(0 < float(r["seconds_per_generation"]) < math.inf for r in data)


def test_gpu_request_without_gpu_is_skipped_with_a_note(tmp_path, capsys):
    assert runner.main(["fig8", "--quick", "--device", "gpu", "--out", str(tmp_path)]) == 0
    if not gpu_status()[0]:
        assert "pending" in capsys.readouterr().out
        assert "deik experiments fig8 fig9 --device gpu" in (tmp_path / "fig8.md").read_text()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["fig1", "--out", "{tmp}"], "unknown experiment 'fig1'; choose from fig2, fig3"),
        (["fig2", "--out", "{tmp}/file"], "is a file, not a folder"),
        (["fig2", "--out", "{tmp}", "--doc", "{tmp}/d.md"], "--doc needs all experiments"),
        (["--out", "{tmp}"], "required"),
        (["fig2"], "required: --out"),
    ],
)
def test_bad_input_is_one_line_and_status_2(tmp_path, capsys, argv, message):
    (tmp_path / "file").write_text("x")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert runner.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and message in err and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_help_returns_zero(capsys):
    assert runner.main(["--help"]) == 0
    assert "deik experiments" in capsys.readouterr().out


def test_sequential_selection_challenges_each_individual_once_per_epoch():
    problem = make_problem(4, 0)
    sequential = SequentialSerialDE(problem, population=12, seed=3).init()
    for _ in range(2):
        assert [step.x for step in sequential.epoch(record=True)] == list(range(12))
    random = SerialDE(problem, population=12, seed=3).init()
    assert [step.x for step in random.epoch(record=True)] != list(range(12))


def test_quantiles_count_never_converged_runs_instead_of_dropping_them():
    values = [1.0, 2.0, 3.0, math.inf]
    assert quantile(values, 0.5) == 2.5 and quantile(values, 1.0) == math.inf
    s = spread(values)
    assert s["n"] == 4 and s["never"] == 1 and s["q3"] == math.inf and s["min"] == 1.0
    assert spread([math.inf] * 3)["median"] == math.inf


def _fake_experiment(name, failure=None):
    """An experiment that writes NAME.csv and NAME.png, then raises `failure` (if any) before
    its section is written."""
    from deik.experiments.shared import Section, write_csv
    from deik.io.atomic import write_text_atomically

    def run(out_dir, quick, device):
        write_csv(f"{out_dir}/{name}.csv", [{"seed": 0, "value": 1.0}])
        write_text_atomically(f"{out_dir}/{name}.png", "not really a picture")
        if failure is not None:
            raise failure
        return Section(
            name=name,
            title=f"Fig. {name}: x",
            claim="claim",
            headline="headline",
            measurement="measurement",
            differences="differences",
            command="command",
        )

    return run


@pytest.mark.parametrize(
    "failure, status, message",
    [
        (KeyboardInterrupt(), 130, "deik: interrupted; the figures finished are kept whole (fa)"),
        (OSError(28, "No space left on device"), 2, "deik: error: "),
    ],
)
def test_ctrl_c_or_a_full_disk_keeps_finished_figures_whole_and_writes_no_half_set(
    tmp_path, capsys, monkeypatch, failure, status, message
):
    fakes = {"fa": _fake_experiment("fa"), "fb": _fake_experiment("fb", failure), "fc": _fake_experiment("fc")}
    monkeypatch.setattr(runner, "EXPERIMENTS", fakes)
    assert runner.main(["all", "--out", str(tmp_path), "--quiet"]) == status
    err = capsys.readouterr().err
    assert err.startswith(message) and err.count("\n") == 1 and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fa.csv", "fa.md", "fa.png"]  # no fb file, no report
