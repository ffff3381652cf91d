"""The GPU check: every figure of issue 25's targets table on an NVIDIA GPU (H100, H200), with
the same machine's CPU beside it in the same run, in at most 8 minutes including compilation.

    PYTHONPATH=src python benchmarks/gpu_check.py [OUT] [--quick] [--cpu-only] [--budget S] [--store-crossover]
                                                  [--keep-cache]

OUT (default benchmarks/results/gpu) receives gpu_check.json, rewritten after every stage so
that a run cut short keeps what finished, and gpu_check.md, the targets table. Robots: the Panda
from ../shared/data/robots/panda.urdf when present, else benchmarks/gpu_robots/panda.urdf, a
git-ignored copy to place there (and carry with the tree) before running on a machine without
../shared. --quick: small sizes (Panda batches of 1 and 2, one timed solve each), for Numba's
CUDA simulator (NUMBA_ENABLE_CUDASIM=1) or a check of the script; --cpu-only: the CPU columns
alone (no GPU needed); --budget: seconds after which the remaining stages are skipped (default
420); --store-crossover: keep the measured CPU/GPU
crossovers for device="auto" on this machine (deik.solver.routing); --keep-cache: use this
machine's kernel cache instead of an empty one (the tests' simulator run).

Stages: first GPU solve in a fresh process with an empty kernel cache, then in a second process;
Panda strict 6-D batches (1e-5 m, 1e-4 rad; population 32, mid-limit start; every answer
re-scored by deik's float64 FK and the joint limits) of 1 to 10,000 targets through a reused
Solver, GPU and CPU, with launches and bytes per GPU solve; the first polish by a team of threads
per problem against a thread per problem on the same batches, taking turns in one Solver (the
speed-up of deik.backends.cuda_team); DE-only joint evaluations per second
on 100-link chains (one problem at population 500, and a batch filling the GPU); the kernels'
registers, local and shared memory and occupancy; a profile of the GPU solves (deik's functions,
ms per solve); the crossovers.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROBOT_FOLDERS = (HERE.parents[1] / "shared" / "data" / "robots", HERE / "gpu_robots")
PANDA = ("panda.urdf", "panda_link0", "panda_hand_tcp")
STRICT = (1e-5, 1e-4)  # metres, radians
TARGETS = {  # issue 25's targets table
    "panda_2000_ms": ("Panda 2,000 strict targets, one batch", "5 ms or less"),
    "panda_10000_per_s": ("Panda 10,000 strict targets", "1,000,000/s or more and 10x the CPU"),
    "one_target_ms": ("one target on the GPU", "1 ms or less (or auto routes it to the CPU)"),
    "de_fill_evals_per_s": ("DE joint evaluations/s, batch filling the GPU", "1e11 or more"),
    "de_one_problem_ratio": ("DE, one problem, population 500, 100 links (GPU/CPU)", "faster than the CPU"),
    "first_solve_s": ("first GPU solve, fresh install / second process", "30 s / 3 s"),
}


def main(argv: list[str]) -> int:
    args = [a for a in argv if not a.startswith("--")]
    flags = {a for a in argv if a.startswith("--")}
    budget = float(argv[argv.index("--budget") + 1]) if "--budget" in argv else 420.0
    if "--budget" in argv:
        args.remove(argv[argv.index("--budget") + 1])
    if "--first-solve" in flags:
        return first_solve(args[0])
    out = Path(args[0]) if args else HERE / "results" / "gpu"
    out.mkdir(parents=True, exist_ok=True)
    if "--keep-cache" in flags:  # the cache this machine has: first solves then measure loading it
        cache = os.environ.get("NUMBA_CACHE_DIR", "")
    else:
        cache = tempfile.mkdtemp(prefix="deik-gpu-check-")  # an empty kernel cache: a fresh install
        os.environ["NUMBA_CACHE_DIR"] = cache  # before Numba loads: every stage below shares it
    check = Check(out, budget, quick="--quick" in flags, devices=("cpu",) if "--cpu-only" in flags else ("gpu", "cpu"))
    check.stage("environment", check.environment)
    check.stage("first_solve", lambda: check.first_solves(cache))
    check.stage("panda", check.panda)
    check.stage("polish", check.polish)
    check.stage("evolution", check.evolution)
    check.stage("profile", check.profile)
    check.stage("kernels", check.kernels)
    check.stage("crossover", lambda: check.crossover("--store-crossover" in flags))
    check.write_markdown()
    return 0


def first_solve(device: str) -> int:
    """(in a subprocess) Seconds from the start to a first answer, then a second, as JSON."""
    began = time.perf_counter()
    import deik

    skeleton, problem, start = panda_problem(1)
    first = time.perf_counter()
    deik.solve(problem, population=32, device=device, seed=1, initial=start)
    done = time.perf_counter()
    deik.solve(problem, population=32, device=device, seed=2, initial=start)
    print(json.dumps({"import_s": first - began, "first_s": done - began, "next_s": time.perf_counter() - done}))
    return 0


def panda_problem(n: int, seed: int = 7):
    """(skeleton, strict 6-D Problem of n targets, mid-limit start pose)."""
    import deik

    folder = next((f for f in ROBOT_FOLDERS if (f / PANDA[0]).is_file()), None)
    if folder is None:
        raise SystemExit(f"no {PANDA[0]} in {' or '.join(map(str, ROBOT_FOLDERS))}: place a copy in the second")
    skeleton = deik.read_urdf(folder / PANDA[0], PANDA[1], PANDA[2])
    q = np.random.default_rng(seed).uniform(skeleton.lower, skeleton.upper, (n, skeleton.n_dofs))
    kin = deik.forward_kinematics(skeleton, q)
    goals = [
        deik.Position(PANDA[2], kin.position(PANDA[2]), tolerance=STRICT[0]),
        deik.Orientation(PANDA[2], kin.rotation(PANDA[2]), tolerance=STRICT[1]),
    ]
    return skeleton, deik.Problem(skeleton, goals), 0.5 * (skeleton.lower + skeleton.upper)


def strict_share(skeleton, angles, problem) -> float:
    """The share of answers within STRICT of their targets (deik's float64 FK) and the limits."""
    import deik

    a = np.asarray(angles, np.float64).reshape(-1, skeleton.n_dofs)
    kin = deik.forward_kinematics(skeleton, a)
    goal_p, goal_r = problem.goals[0].target, problem.goals[1].target
    dp = np.linalg.norm(kin.position(PANDA[2]) - np.reshape(goal_p, (-1, 3)), axis=1)
    trace = np.einsum("nij,nij->n", kin.rotation(PANDA[2]), np.reshape(goal_r, (-1, 3, 3)))
    angle = np.arccos(np.clip((trace - 1) / 2, -1, 1))
    inside = np.all((a >= skeleton.lower - 1e-9) & (a <= skeleton.upper + 1e-9), axis=1)
    return float(np.mean((dp <= STRICT[0]) & (angle <= STRICT[1]) & inside))


class Check:
    """The stages of one run and what they found (`results`, written as they come)."""

    def __init__(self, out: Path, budget: float, quick: bool, devices: tuple[str, ...]):
        self.out, self.budget, self.quick, self.devices = out, budget, quick, devices
        self.began = time.perf_counter()
        self.results: dict = {"devices": list(devices), "quick": quick, "budget_s": budget}

    def stage(self, name: str, work) -> None:
        if time.perf_counter() - self.began > self.budget:
            self.results[name] = {"skipped": f"over the {self.budget:.0f} s budget"}
        else:
            began = time.perf_counter()
            try:
                self.results[name] = work()
            except Exception as error:  # noqa: BLE001 - one stage's failure must not lose the others'
                self.results[name] = {"error": f"{type(error).__name__}: {error}"[:500]}
            self.results.setdefault("stage_seconds", {})[name] = round(time.perf_counter() - began, 2)
        self.results["elapsed_s"] = round(time.perf_counter() - self.began, 2)
        (self.out / "gpu_check.json").write_text(json.dumps(self.results, indent=1, default=str) + "\n")
        print(f"[{self.results['elapsed_s']:7.1f} s] {name}: {json.dumps(self.results[name], default=str)[:300]}")

    def environment(self) -> dict:
        import numba

        import deik

        sys.path.insert(0, str(HERE.parent))  # run as a script: the benchmarks package from the root
        from benchmarks.harness import cpu_info

        model, flags = cpu_info()
        env = {
            "deik": deik.__version__,
            "cpu_model": model,
            "cpu_flags": flags,
            "numba": numba.__version__,
            "numpy": np.__version__,
            "cpus": os.cpu_count(),
            "load_average": os.getloadavg()[0],
        }
        if "gpu" in self.devices:
            from deik.backends.gpu import require_gpu, simulated

            cuda = require_gpu()
            device = cuda.get_current_device()
            name = "CUDA simulator" if simulated() else device.name
            env.update(
                gpu=name.decode() if isinstance(name, bytes) else str(name),
                compute_capability=getattr(device, "compute_capability", None),
                multiprocessors=getattr(device, "MULTIPROCESSOR_COUNT", None),
            )
        return env

    def first_solves(self, cache: str) -> dict:
        device = self.devices[0]
        env = {**os.environ, "PYTHONPATH": os.environ.get("PYTHONPATH", "src")}
        if cache:
            env["NUMBA_CACHE_DIR"] = cache
        runs = []
        for _ in range(2):  # the empty cache, then the cache the first filled
            done = subprocess.run(
                [sys.executable, "-W", "ignore", __file__, "--first-solve", device],
                env=env,
                capture_output=True,
                text=True,
                timeout=600,
            )
            if done.returncode:
                raise RuntimeError(done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "failed")
            runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
        return {"device": device, "fresh_cache": runs[0], "second_process": runs[1]}

    def panda(self) -> dict:
        import deik

        sizes = (1, 2) if self.quick else (1, 100, 2000, 10000)
        repeats = 1 if self.quick else 3
        skeleton, problem, start = panda_problem(2 * max(sizes))
        positions, rotations = problem.goals[0].target, problem.goals[1].target
        rows = {}
        for device in self.devices:
            for n in sizes:
                sets = [
                    {
                        "position " + PANDA[2]: positions[k * n : (k + 1) * n],
                        "orientation " + PANDA[2]: rotations[k * n : (k + 1) * n],
                    }
                    for k in range(2)
                ]
                _, batch, _ = panda_problem(n)
                solver = deik.Solver(batch, population=32, device=device, seed=1)
                solver.solve(sets[1], initial=start[None])  # compile or load, allocate, upload
                traffic = getattr(solver._engine.backend, "traffic", None)
                before = dict(vars(traffic)) if traffic else {}
                times, result = [], None
                for rep in range(repeats):
                    began = time.perf_counter()
                    result = solver.solve(sets[rep % 2], initial=start[None])
                    times.append(time.perf_counter() - began)
                # the last solve's targets were sets[0] (repeats is odd): the first n
                scored = deik.Problem(
                    skeleton, [deik.Position(PANDA[2], positions[:n]), deik.Orientation(PANDA[2], rotations[:n])]
                )
                row = {
                    "best_ms": 1e3 * min(times),
                    "problems_per_s": n / min(times),
                    "strict": strict_share(skeleton, result.angles, scored),
                    "generations_median": float(np.median(result.generations)),
                }
                if traffic:
                    row.update({k: (v - before[k]) / repeats for k, v in vars(traffic).items()})
                rows[f"{device}/{n}"] = row
                if time.perf_counter() - self.began > self.budget:
                    return {"rows": rows, "cut": "budget"}
        return {"rows": rows, "auto_for_one": _auto_device(panda_problem(1)[1])}

    def polish(self) -> dict:
        """The first polish on Panda strict batches, a team of threads per problem against a thread
        per problem (CudaBackend.cooperative_polish), taking turns on one reused Solver: best ms
        of 3 each (1 at --quick sizes), the ratio, the strict share of each one's answers."""
        if "gpu" not in self.devices:
            return {"skipped": "no GPU in this run"}
        import deik

        sizes, rounds = ((2,), 2) if self.quick else ((100, 2000, 10000), 4)
        rows = {}
        for n in sizes:
            skeleton, batch, start = panda_problem(n, seed=5)
            solver = deik.Solver(batch, population=32, device="gpu", seed=1)
            backend = solver._engine.backend
            times, strict = {True: [], False: []}, {}
            for rep in range(rounds):  # the first round compiles or loads each kernel and allocates
                for team in (True, False):
                    backend.cooperative_polish = team
                    began = time.perf_counter()
                    result = solver.solve(initial=start[None])
                    if rep:
                        times[team].append(time.perf_counter() - began)
                    strict[team] = strict_share(skeleton, result.angles, batch)
            ran = "first_polish_team" if backend.team_pool is not None else "first_polish"
            team_ms, thread_ms = 1e3 * min(times[True]), 1e3 * min(times[False])
            rows[f"gpu/{n}"] = {
                "team_ms": team_ms,
                "thread_ms": thread_ms,
                "speedup": thread_ms / team_ms,
                "team_strict": strict[True],
                "thread_strict": strict[False],
                "team_kernel": ran,
            }
            if time.perf_counter() - self.began > self.budget:
                return {"rows": rows, "cut": "budget"}
        return {"rows": rows}

    def evolution(self) -> dict:
        import deik

        links, population = (10, 16) if self.quick else (100, 500)
        rows = {}
        for device in self.devices:
            fill = 4 * (self.results.get("environment", {}).get("multiprocessors") or 132)
            batches = (1, 2 if self.quick else (fill if device == "gpu" else 64))
            for batch in batches:
                chain = deik.chain(links)
                q = np.random.default_rng(3).uniform(chain.lower, chain.upper, (batch, chain.n_dofs))
                problem = deik.Problem(chain, [deik.Position("tip", deik.forward_kinematics(chain, q).position("tip"))])
                settings = deik.Settings(
                    population=population,
                    generations=10**6,
                    polish=0,
                    restarts=0,
                    seed=1,
                    stop_on_converged=False,
                    patience=10**9,
                    device=device,
                    dtype="float32",
                )
                engine = deik.Engine(problem, settings)
                state = engine.run(engine.init(), 2)
                generations, seconds = 2 if self.quick else 20, 0.0
                while True:
                    began = time.perf_counter()
                    engine.run(state, generations)
                    seconds = time.perf_counter() - began
                    if self.quick or seconds > 0.4 or generations > 50_000:
                        break
                    generations *= 4
                rows[f"{device}/{batch}"] = {
                    "links": links,
                    "population": population,
                    "generations": generations,
                    "seconds": seconds,
                    "joint_evaluations_per_s": population * links * batch * generations / seconds,
                }
        return {"rows": rows}

    def profile(self) -> dict:
        """Where a reused Solver's GPU solve of Panda strict batches spends its time: cProfile of
        3 solves, milliseconds per solve in each of deik's functions (cumulative, the top 12),
        and how many problems ran how many generations."""
        if "gpu" not in self.devices:
            return {"skipped": "no GPU in this run"}
        import cProfile
        import pstats

        import deik

        rows = {}
        for n in (2,) if self.quick else (2000, 10000):
            _, batch, start = panda_problem(n)
            solver = deik.Solver(batch, population=32, device="gpu", seed=1)
            result = solver.solve(initial=start[None])
            profiler = cProfile.Profile()
            profiler.enable()
            for _ in range(3):
                solver.solve(initial=start[None])
            profiler.disable()
            stats = pstats.Stats(profiler).stats  # (file, line, name) -> (calls, calls, own s, cumulative s, callers)
            ours = {f"{Path(f).name}:{name}": 1e3 * v[3] / 3 for (f, _, name), v in stats.items() if "deik" in f}
            rows[f"gpu/{n}"] = {
                "ms_per_solve": dict(sorted(ours.items(), key=lambda kv: -kv[1])[:12]),
                "generations": np.bincount(np.asarray(result.generations, int)).tolist(),
            }
        return rows

    def kernels(self) -> dict:
        if "gpu" not in self.devices:
            return {"skipped": "no GPU in this run"}
        from deik.backends import cuda_kernels, cuda_team

        rows = {}
        for name in ("first_polish", "first_polish_team", "evolve"):
            kernel = getattr(cuda_team if name.endswith("team") else cuda_kernels, name)
            rows[name] = {
                query: _first_value(kernel, query)
                for query in ("get_regs_per_thread", "get_local_mem_per_thread", "get_shared_mem_per_block")
            }
        return rows

    def crossover(self, store: bool) -> dict:
        panda = self.results.get("panda", {}).get("rows", {})
        evolution = self.results.get("evolution", {}).get("rows", {})
        found = {}
        fits = {
            d: _line({int(k.split("/")[1]): v["best_ms"] for k, v in panda.items() if k.startswith(d)})
            for d in ("gpu", "cpu")
        }
        if all(fits.values()):
            (g0, g1), (c0, c1) = fits["gpu"], fits["cpu"]
            found["polish_problems"] = (g0 - c0) / (c1 - g1) if c1 > g1 else None  # None: never
        one_gpu, one_cpu = evolution.get("gpu/1"), evolution.get("cpu/1")
        if one_gpu and one_cpu:
            per_problem = one_gpu["population"] * (one_gpu["links"] + 1)
            ratio = one_gpu["joint_evaluations_per_s"] / one_cpu["joint_evaluations_per_s"]
            found["evolution_work"] = per_problem / max(ratio, 1e-9)  # the GPU's rate grows with the batch
        if store and found and "gpu" in self.devices:
            from deik.solver.routing import store_crossover

            never = 1e18  # the GPU was not faster at any size measured: auto keeps such solves on the CPU
            found["stored_in"] = store_crossover({k: never if v is None else v for k, v in found.items()})
        return found

    def write_markdown(self) -> None:
        r, env = self.results, self.results.get("environment", {})
        panda = r.get("panda", {}).get("rows", {})
        evolution = r.get("evolution", {}).get("rows", {})
        first = r.get("first_solve", {})

        def cell(row, key, scale=1.0, unit=""):
            return f"{row[key] * scale:,.3g}{unit}" if row and isinstance(row.get(key), (int, float)) else "-"

        gpu_fill = next((v for k, v in evolution.items() if k.startswith("gpu/") and k != "gpu/1"), None)
        ratio = "-"
        if evolution.get("gpu/1") and evolution.get("cpu/1"):
            ratio = (
                f"{evolution['gpu/1']['joint_evaluations_per_s'] / evolution['cpu/1']['joint_evaluations_per_s']:.2f}x"
            )
        firsts = (
            "-"
            if "fresh_cache" not in first
            else (f"{first['fresh_cache']['first_s']:.1f} s / {first['second_process']['first_s']:.1f} s")
        )
        measured = {
            "panda_2000_ms": f"GPU {cell(panda.get('gpu/2000'), 'best_ms', unit=' ms')}, "
            f"CPU {cell(panda.get('cpu/2000'), 'best_ms', unit=' ms')}",
            "panda_10000_per_s": f"GPU {cell(panda.get('gpu/10000'), 'problems_per_s', unit='/s')}, "
            f"CPU {cell(panda.get('cpu/10000'), 'problems_per_s', unit='/s')}",
            "one_target_ms": f"GPU {cell(panda.get('gpu/1'), 'best_ms', unit=' ms')}, CPU "
            f"{cell(panda.get('cpu/1'), 'best_ms', unit=' ms')}; auto: {r.get('panda', {}).get('auto_for_one', '-')}",
            "de_fill_evals_per_s": cell(gpu_fill, "joint_evaluations_per_s"),
            "de_one_problem_ratio": ratio,
            "first_solve_s": firsts,
        }
        lines = [
            f"# deik GPU check: {env.get('gpu', 'no GPU')} beside {env.get('cpus', '?')} CPU cores "
            f"({env.get('cpu_model', '?')}; {' '.join(env.get('cpu_flags', []))})",
            "",
            f"`{' '.join(['python', 'benchmarks/gpu_check.py', *sys.argv[1:]])}`; deik {env.get('deik')}, "
            f"numba {env.get('numba')}, NumPy {env.get('numpy')}; quick sizes: {r.get('quick')}.",
            "",
            "| measure | this run | target |",
            "|---|---|---|",
        ]
        lines += [f"| {TARGETS[key][0]} | {measured[key]} | {TARGETS[key][1]} |" for key in TARGETS]
        lines += [
            "",
            "| Panda strict batch | ms | problems/s | strict | launches/solve | bytes in/out per solve |",
            "|---|---|---|---|---|---|",
        ]
        for key, row in panda.items():
            moved = f"{row['bytes_to_device']:,.0f} / {row['bytes_to_host']:,.0f}" if "launches" in row else "-"
            lines.append(
                f"| {key} | {row['best_ms']:.3f} | {row['problems_per_s']:,.0f} | {row['strict']:.1%} | "
                f"{row.get('launches', '-')} | {moved} |"
            )
        polish = r.get("polish", {}).get("rows", {})
        if polish:
            lines += [
                "",
                "| first polish, Panda strict batch | team of threads ms | thread per problem ms | speed-up | strict |",
                "|---|---|---|---|---|",
            ]
            for key, row in polish.items():
                lines.append(
                    f"| {key} ({row['team_kernel']}) | {row['team_ms']:.3f} | {row['thread_ms']:.3f} | "
                    f"{row['speedup']:.2f}x | {row['team_strict']:.1%} / {row['thread_strict']:.1%} |"
                )
        lines += [
            "",
            f"Kernels: `{json.dumps(r.get('kernels'))}`; crossovers: `{json.dumps(r.get('crossover'), default=str)}`.",
        ]
        (self.out / "gpu_check.md").write_text("\n".join(lines) + "\n")


def _auto_device(problem) -> str:
    """Where device="auto" sends a solve of `problem` on this machine."""
    import deik

    engine = deik.Engine(problem, deik.Settings(population=32, device="auto"))
    return engine.settings.device


def _first_value(kernel, query: str):
    try:
        value = getattr(kernel, query)()
    except Exception:  # noqa: BLE001 - the simulator has no resource queries
        return None
    return next(iter(value.values()), None) if isinstance(value, dict) else value


def _line(points: dict) -> tuple[float, float] | None:
    """(intercept, slope) of ms against problems, least squares, or None with fewer than 2 sizes."""
    if len(points) < 2:
        return None
    slope, intercept = np.polyfit(list(points), list(points.values()), 1)
    return float(intercept), float(slope)


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
