"""The robot benchmark's report: a markdown table per case and a success-against-time figure."""

from __future__ import annotations

from pathlib import Path

from benchmarks.serial_vs_parallel import write_atomic


def note(row: dict) -> str:
    """The note column: deik's batch and reused Solver; a peer's restarts."""
    parts = []
    if "batch" in row:
        b = row["batch"]
        parts.append(
            f"batch of {b['batch_size']} x {b['batches']}: {b['problems_per_second']:.0f} problems/s, "
            f"strict {100 * b['success_strict']:.1f} %, loose {100 * b['success_loose']:.1f} %"
        )
    if "solver" in row:
        s = row["solver"]
        parts.append(
            f"deik.Solver reused: median {s['median_ms']:.2f} ms, p95 {s['p95_ms']:.2f} ms, "
            f"strict {100 * s['success_strict']:.1f} %, ≤5 ms {100 * s['success_strict_within_budget']:.1f} %"
        )
    if "attempts" in row:
        a = row["attempts"]
        parts.append(f"attempts: mean {a['mean']:.2f}, max {a['max']}, restarted {100 * a['restarted']:.1f} %")
    return "; ".join(parts)


def markdown(result: dict) -> str:
    """One table per case: success rates and times per solver."""
    s = result["settings"]
    lines = [
        f"Robot IK, TRAC-IK protocol: {s['targets']} random in-limit targets per case in {s['chunks']} chunks, "
        "every solver taking its turn on each chunk; start at mid-limits, local peers restart from random "
        "in-limit poses within 5 ms per target; scored by deik's float64 FK. strict = 1e-5 m and 1e-4 rad with "
        "joints in limits; loose = 1e-3 m and 1e-2 rad; ≤5 ms = strict within 5 ms. Times per target; "
        f"CPU {result['environment'].get('cpu_model', '?')}, shared, timings noisy."
    ]
    for case, data in result["cases"].items():
        lines += [
            "",
            f"### {case} ({data['dofs']} DOF, {data['base']} -> {data['tip']})",
            "",
            "| solver | version | strict | loose | ≤5 ms | median ms | p95 ms | note |",
            "|---|---|---:|---:|---:|---:|---:|---|",
        ]
        for name, row in data["solvers"].items():
            if "skipped" in row:
                lines.append(f"| {name} | | | | | | | skipped: {row['skipped'][:120]} |")
                continue
            lines.append(
                f"| {name} | {row['version']} | {100 * row['success_strict']:.1f} % | "
                f"{100 * row['success_loose']:.1f} % | {100 * row['success_strict_within_budget']:.1f} % | "
                f"{row['median_ms']:.2f} | {row['p95_ms']:.2f} | {note(row)} |"
            )
    return "\n".join(lines) + "\n"


def plot(result: dict, path: Path, budget_s: float) -> None:
    """Strict success rate against median time per solve (bar to the 95th percentile), per case."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = result["cases"]
    fig, axes = plt.subplots(1, len(cases), figsize=(4.6 * len(cases), 4.0), squeeze=False)
    for ax, (case, data) in zip(axes[0], cases.items()):
        for k, (name, row) in enumerate((n, r) for n, r in data["solvers"].items() if "skipped" not in r):
            colour = f"C{k % 10}"
            y = 100 * row["success_strict"]
            ax.plot([row["median_ms"], row["p95_ms"]], [y, y], "-", color=colour, alpha=0.5)
            ax.plot(row["median_ms"], y, "o", color=colour, label=name)
            if "solver" in row:
                s = row["solver"]
                y = 100 * s["success_strict"]
                ax.plot([s["median_ms"], s["p95_ms"]], [y, y], "-", color=colour, alpha=0.5)
                ax.plot(s["median_ms"], y, "s", color=colour, label=f"{name} reused Solver")
            if "batch" in row:
                per = 1e3 / row["batch"]["problems_per_second"]
                label = f"{name} batch (amortised)"
                ax.plot(per, 100 * row["batch"]["success_strict"], "*", ms=11, color=colour, label=label)
        ax.axvline(budget_s * 1e3, color="grey", ls=":", lw=1)
        ax.set_xscale("log")
        ax.set_ylim(-3, 103)
        ax.set_xlabel("time per target, ms (median; line to p95)")
        ax.set_ylabel("success 1e-5 m / 1e-4 rad, %")
        ax.set_title(f"{case} ({data['dofs']} DOF)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)
