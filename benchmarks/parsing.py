"""Parsing speed and its growth: large URDF robots and BVH clips, read in one process.

Issue 16's targets: a 2,000-link URDF in under 0.5 s, a 200,000-frame BVH in under 5 s, and
time that grows linearly with links, joints and frames (the ratio of the time for twice the
size is reported; 2 is linear, 4 quadratic). Files are generated into a temporary folder:
a serial chain of revolute joints (URDF), a 13-joint, 42-channel clip with N frames, a chain N
joints deep (BVH), and a root with N sibling joints, read and described as `deik info` does
(issue 29: 20,000 siblings took 59 s, a quadratic scan). Each size is read `--repeats` times,
best kept; the first read of a URDF in a fresh process (imports included) is timed too, and the
peak memory a fresh process adds reading the largest clip is reported over the file's size
(issue 29: 8x before the frames were streamed).

    python -m benchmarks.parsing            # full sizes, results/parsing.{json,md,png}
    python -m benchmarks.parsing --quick    # small sizes, a few seconds
"""

from __future__ import annotations

import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import deik
from benchmarks import harness


def urdf_chain(n: int) -> str:
    """A URDF of n links joined by revolute joints."""
    out = ['<?xml version="1.0"?>', '<robot name="chain">', '<link name="l0"/>']
    for k in range(1, n):
        out += [
            f'<link name="l{k}"><inertial><mass value="1"/></inertial></link>',
            f'<joint name="j{k}" type="revolute"><parent link="l{k - 1}"/><child link="l{k}"/>'
            '<origin xyz="0 0 0.01" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1"/></joint>',
        ]
    return "\n".join(out + ["</robot>"]) + "\n"


def bvh_frames(n: int) -> str:
    """A 13-joint chain clip (root with 6 channels, 12 joints with 3) of n frames."""
    lines = [
        "HIERARCHY",
        "ROOT j0",
        "{",
        "OFFSET 0 0 0",
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
    ]
    for k in range(1, 13):
        lines += [f"JOINT j{k}", "{", "OFFSET 0 0.1 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    lines += ["End Site", "{", "OFFSET 0 0.1 0", "}"] + ["}"] * 13
    row = " ".join(f"{0.5 + 0.01 * c:.3f}" for c in range(42))
    return "\n".join(lines + ["MOTION", f"Frames: {n}", "Frame Time: 0.033333"] + [row] * n) + "\n"


def bvh_deep(n: int) -> str:
    """A one-frame clip whose hierarchy is a chain n joints deep."""
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    for k in range(1, n):
        lines += [f"JOINT j{k}", "{", "OFFSET 0 0.01 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    lines += ["End Site", "{", "OFFSET 0 0.01 0", "}"] + ["}"] * n
    return "\n".join(lines + ["MOTION", "Frames: 1", "Frame Time: 0.033333", " ".join(["0"] * (3 * n))]) + "\n"


def bvh_siblings(n: int) -> str:
    """A one-frame clip whose root has n child joints, each with an End Site."""
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    for k in range(1, n + 1):
        lines += [
            f"JOINT j{k}",
            "{",
            "OFFSET 0 0.1 0",
            "CHANNELS 1 Zrotation",
            "End Site",
            "{",
            "OFFSET 0 0.1 0",
            "}",
            "}",
        ]
    return "\n".join(lines + ["}", "MOTION", "Frames: 1", "Frame Time: 0.033333", " ".join(["0"] * (3 + n))]) + "\n"


def info(path: Path) -> str:
    """What `deik info` prints for the file at `path` (read and described)."""
    from deik.cli.info_command import describe
    from deik.io.load import load_skeleton

    return describe(load_skeleton(str(path)), str(path))


def peak_read_memory(path: Path) -> float:
    """Peak resident memory a fresh process adds while it reads the BVH at `path`, over its size."""
    code = (  # VmHWM, the process's own peak (ru_maxrss keeps the forking parent's)
        "import sys, deik; from deik.io.bvh import read_bvh; "
        "status = lambda key: int(open('/proc/self/status').read().split(key + ':')[1].split()[0]); "
        "before = status('VmRSS'); read_bvh(sys.argv[1]); print(status('VmHWM') - before)"
    )
    run = subprocess.run([sys.executable, "-c", code, str(path)], check=True, capture_output=True, text=True)
    return int(run.stdout) * 1024 / path.stat().st_size


def best_time(read, path: Path, repeats: int) -> float:
    """Best of `repeats` wall times (s) of read(path)."""
    times = []
    for _ in range(repeats):
        began = time.perf_counter()
        read(path)
        times.append(time.perf_counter() - began)
    return min(times)


def first_read_in_fresh_process(path: Path) -> float:
    """Seconds from `import deik` to a read URDF skeleton in a new interpreter (imports included)."""
    code = (
        f"import time; t = time.perf_counter(); import deik; deik.read_urdf({str(path)!r}); "
        "print(time.perf_counter() - t)"
    )
    return float(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout)


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--repeats", type=int, default=3)
    run = harness.start("parsing", p, argv)
    args = run.args
    sizes = (
        {"urdf": [250, 500], "frames": [5_000, 10_000], "deep": [500, 1_000], "siblings": [500, 1_000]}
        if args.quick
        else {
            "urdf": [1_000, 2_000, 4_000],
            "frames": [50_000, 100_000, 200_000],
            "deep": [5_000, 10_000, 20_000],
            "siblings": [5_000, 10_000, 20_000],
        }
    )
    makers = {
        "urdf": (urdf_chain, deik.read_urdf, ".urdf", "URDF links"),
        "frames": (bvh_frames, deik.read_bvh, ".bvh", "BVH frames"),
        "deep": (bvh_deep, deik.read_bvh, ".bvh", "BVH joints deep"),
        "siblings": (bvh_siblings, info, ".bvh", "info, sibling joints"),  # read and described, as deik info
    }
    series, cells = {}, []
    fig, axes = harness.figure()
    with tempfile.TemporaryDirectory() as folder:
        for kind, counts in sizes.items():
            make, read, suffix, label = makers[kind]
            warm = Path(folder) / f"warm{suffix}"
            warm.write_text(make(10))
            read(warm)  # imports and first-call costs are not parsing (the fresh-process figure has them)
            series[kind] = []
            for n in counts:
                path = Path(folder) / f"{kind}_{n}{suffix}"
                path.write_text(make(n))
                point = {"size": n, "seconds": best_time(read, path, args.repeats), "bytes": path.stat().st_size}
                if series[kind]:  # 2 ** (the exponent of the growth): 2 linear, 4 quadratic
                    before = series[kind][-1]
                    exponent = math.log2(point["seconds"] / before["seconds"]) / math.log2(n / before["size"])
                    point["growth_for_double"] = 2**exponent
                series[kind].append(point)
                cells.append([kind, n, f"{point['seconds']:.3f}", f"{point.get('growth_for_double', math.nan):.2f}"])
            axes[0, 0].plot(counts, [s["seconds"] for s in series[kind]], "o-", label=label)
        largest = Path(folder) / f"frames_{sizes['frames'][-1]}.bvh"
        peak = peak_read_memory(largest) if sys.platform.startswith("linux") else math.nan
        fresh = Path(folder) / "fresh.urdf"
        fresh.write_text(urdf_chain(sizes["urdf"][-1]))
        first_read = first_read_in_fresh_process(fresh)
    at = {kind: {s["size"]: s["seconds"] for s in series[kind]} for kind in series}
    # at --quick sizes the largest measured file stands in, and the verdict is "not judged here"
    urdf, bvh = at["urdf"].get(2000, max(at["urdf"].values())), at["frames"].get(200_000, max(at["frames"].values()))
    run.target("URDF of 2,000 links read", 0.5, urdf, "s", not args.quick, at_most=True)
    run.target("BVH of 200,000 frames read", 5.0, bvh, "s", not args.quick, at_most=True)
    harness.style_axes(axes[0, 0], "size (links, frames or joints)", "seconds (best of repeats)", "Parsing time")
    body = harness.md_table(["file", "size", "seconds", "growth for double (2 = linear)"], cells)
    body += f"\nFirst read of the largest URDF in a fresh process (imports included): {first_read:.2f} s\n"
    body += f"\nPeak memory reading the largest BVH, over its size: {peak:.2f}x\n"
    figures = {f"{kind} {s['size']} s": s["seconds"] for kind in series for s in series[kind]}
    result = {
        "series": series,
        "urdf_first_read_fresh_process_s": first_read,
        "bvh_read_peak_memory_over_file_size": peak,
        "quick": args.quick,
    }
    figures |= {"URDF first read in a fresh process, s": first_read, "BVH read peak memory / file size": peak}
    return run.finish(result, body, fig, figures)


if __name__ == "__main__":
    main()
