"""Retargets judged by an independent measurement (judging/retargets.py): every shared
clip and hard cases made from them, onto human.urdf (and robots made from it) and onto the same
rig with other proportions.

    python -m benchmarks.retarget_quality [--quick] [--clips DIR] [--out DIR] [--only TEXT]
    python -m benchmarks.retarget_quality --robot ROBOT.urdf --map MAP.toml --out DIR   # any robot

Each case is retargeted through the command line (`deik retarget`) and judged from the files it
wrote (the trajectory CSV, the BVH). Hard cases (source_case, robot_case): a clip played
backwards, sped up 2x, with its legs 15 % longer (its feet sink), with noise on every channel,
with its feet crossing the midline (both hips turned in 8 degrees), and as another rig family
(centimetres, a Reference root on the floor above the hips, position channels on every joint,
other joint names, 30 fps), the walk, run and kick at 120 fps with capture noise
(judging/cases.py's `_120fps_noisy`, judged against the clip without the noise), and the walk
and kick with that noise at 30 fps (its `_noisy`, judged so); robots made from human.urdf
(another joint order, continuous shoulders and elbows, velocity limits halved, standing on +Z).
Writes retarget_quality.json and retarget_quality.md under --out (benchmarks/harness.py), each
run's judge figures beside deik's own summary; --quick runs the walk alone. With --robot and
--map, every clip as captured onto that robot instead (a robot standing on +Z says so in its
map's `up`).
"""

from __future__ import annotations

import json
import re
import tempfile
import time
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks.data import need, shared_data
from benchmarks.harness import md_table, parser, start
from judging.cases import cases
from judging.retargets import (
    PENETRATION_BOUND,
    SLIDING_BOUND,
    STEP_ALLOWANCE,
    WRIST_BOUND,
    Bvh,
    bvh_transforms,
    judge,
    read_bvh_file,
    read_robot,
    rig_pairing,
    robot_pairing,
    source_floor,
    stature,
    write_bvh_file,
)
from judging.rigs import format_rig

ROOT = Path(__file__).resolve().parents[1]
HUMAN_URDF = shared_data("robots", "human.urdf")
Z_UP_BASE = "z_up_base"  # the root robot_case "z_up" adds
URDF_MAP = ROOT / "examples" / "maps" / "shared_bvh_to_human_urdf.toml"


# --- hard cases -------------------------------------------------------------------------------

STUDIO_NAMES = {  # the shared rig's joints as another studio names them
    "Hips": "pelvis",
    "RightHip": "thigh_r",
    "RightKnee": "calf_r",
    "RightAnkle": "foot_r",
    "LeftHip": "thigh_l",
    "LeftKnee": "calf_l",
    "LeftAnkle": "foot_l",
    "Chest": "spine_03",
    "Neck": "neck_01",
    "RightShoulder": "upperarm_r",
    "RightElbow": "lowerarm_r",
    "LeftShoulder": "upperarm_l",
    "LeftElbow": "lowerarm_l",
}
LEG_NODES = ("RightKnee", "RightAnkle", "RightAnkle_end", "LeftKnee", "LeftAnkle", "LeftAnkle_end")
CROSSING_DEGREES = 8.0  # the feet 3 cm past the midline


def source_case(bvh: Bvh, case: str, seed: int = 0) -> Bvh:
    """`bvh` made harder (module notes): "backwards", "sped_up" (every other frame), "long_legs"
    (thighs, shins and feet 15 % longer, the root's path kept: the feet sink), "noisy" (1 degree
    on every rotation channel, 3 mm on the root's position), "studio" (studio_rig) or
    "crossing" (both hips turned in by CROSSING_DEGREES about the forward axis: the feet land
    across the midline, a catwalk's crossing steps, and the legs pass through each other)."""
    if case == "backwards":
        return replace(bvh, frames=bvh.frames[::-1].copy())
    if case == "sped_up":
        return replace(bvh, frames=bvh.frames[::2].copy())
    if case == "long_legs":
        offsets = bvh.offsets.copy()
        for name in LEG_NODES:
            offsets[bvh.names.index(name)] *= 1.15
        return replace(bvh, offsets=offsets)
    if case == "noisy":
        rng = np.random.default_rng(seed)
        frames = bvh.frames.copy()
        for p, names in enumerate(bvh.channels):
            for column, name in zip(bvh.columns(p), names):
                frames[:, column] += rng.normal(0.0, 1.0 if name.endswith("rotation") else 0.003, len(frames))
        return replace(bvh, frames=frames)
    if case == "studio":
        return studio_rig(bvh, seed)
    if case == "crossing":
        frames = bvh.frames.copy()
        for hip, inwards in (("RightHip", 1.0), ("LeftHip", -1.0)):  # +X turns the right leg in
            p = bvh.names.index(hip)
            frames[:, dict(zip(bvh.channels[p], bvh.columns(p)))["Xrotation"]] += inwards * CROSSING_DEGREES
        return replace(bvh, frames=frames)
    raise ValueError(f"unknown case {case!r}")


def studio_rig(bvh: Bvh, seed: int = 0) -> Bvh:
    """The clip on another rig family: centimetres, a "Reference" root on the floor below the
    hips (its own six channels carry the hips' ground track), position channels on every joint
    (the capture's small values, 0.01 cm of drift), the joints renamed (STUDIO_NAMES), 30 fps."""
    rng = np.random.default_rng(seed)
    step = max(1, round(1 / 30 / bvh.frame_time))
    frames = bvh.frames[::step] * 1.0
    N = len(frames)
    positions = bvh_transforms(replace(bvh, frames=frames))[0]
    ground = positions[:, 0] * [1, 0, 1] * 100.0  # cm: the hips' track on the floor
    hips_rest = bvh.offsets[0] * 100.0 + [0, 100.0 * positions[0, 0, 1], 0]
    names = ["Reference"] + [STUDIO_NAMES.get(n, n) for n in bvh.names]
    names = [STUDIO_NAMES[n[:-4]] + "_end" if n.endswith("_end") else n for n in names]
    parents = [-1] + [p + 1 for p in bvh.parents]
    offsets = np.concatenate([[np.zeros(3)], bvh.offsets * 100.0])
    offsets[1] = hips_rest
    six = ["Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"]
    channels = [six] + [six if c else [] for c in bvh.channels]
    columns = [np.concatenate([ground, np.zeros((N, 3))], axis=1)]
    for p, names_p in enumerate(bvh.channels):
        if not names_p:
            continue
        values = frames[:, bvh.columns(p)]
        rotation = values[:, [k for k, n in enumerate(names_p) if n.endswith("rotation")]]
        if p == 0:
            moved = values[:, :3] * 100.0 - ground - hips_rest
        else:
            moved = rng.normal(0.0, 0.01, (N, 3))
        columns.append(np.concatenate([moved, rotation], axis=1))
    return Bvh(names, parents, offsets, channels, np.concatenate(columns, axis=1), bvh.frame_time * step)


def studio_map(joint_map: dict) -> dict:
    """`joint_map` (parsed) with its source names as studio_rig names them, and the target's
    offsets kept (the target is the same robot)."""

    def rename(name: str) -> str:
        return STUDIO_NAMES[name[:-4]] + "_end" if name.endswith("_end") else STUDIO_NAMES[name]

    out = dict(joint_map)
    out["points"] = {rename(s): t for s, t in joint_map["points"].items()}
    for key in ("pelvis", "torso"):
        if key in joint_map:
            out[key] = {"source": rename(joint_map[key]["source"]), "target": joint_map[key]["target"]}
    return out


def robot_case(urdf_text: str, case: str) -> str:
    """human.urdf's text made harder: "reordered" (its joints in reverse file order: another
    DOF order), "continuous" (shoulders' first and elbows' second joints continuous), "slow"
    (every velocity limit halved) or "z_up" (standing on +Z, as most robots are modelled)."""
    joints = re.findall(r"<joint\b.*?</joint>", urdf_text, flags=re.S)
    if case == "reordered":
        body = urdf_text
        for joint in joints:
            body = body.replace(joint, "", 1)
        return body.replace("</robot>", "\n".join(reversed(joints)) + "\n</robot>")
    if case == "continuous":
        out = urdf_text
        for joint in joints:
            name = re.search(r'name="([^"]+)"', joint)[1]
            if re.fullmatch(r"(left|right)_(shoulder_Z|elbow_Y)", name):
                changed = joint.replace('type="revolute"', 'type="continuous"')
                changed = re.sub(r'\s(lower|upper)="[^"]*"', "", changed)
                out = out.replace(joint, changed)
        return out
    if case == "slow":
        return re.sub(r'velocity="([^"]+)"', lambda m: f'velocity="{float(m[1]) / 2:g}"', urdf_text)
    if case == "z_up":  # its root link under a new one, turned a quarter about X: it stands on +Z
        root = tomllib.loads(URDF_MAP.read_text())["pelvis"]["target"]
        stand = (
            f'<link name="{Z_UP_BASE}"/><joint name="z_up" type="fixed"><parent link="{Z_UP_BASE}"/>'
            f'<child link="{root}"/><origin rpy="{np.pi / 2!r} 0 0"/></joint>'
        )
        return urdf_text.replace("</robot>", stand + "\n</robot>")
    raise ValueError(f"unknown case {case!r}")


def z_up_map(joint_map: dict) -> dict:
    """`joint_map` (human.urdf's) for the robot of robot_case "z_up": up +Z, the source's +Y
    turned onto it (its X kept), the pelvis on the new root."""
    pelvis = {**joint_map["pelvis"], "target": Z_UP_BASE}
    return {**joint_map, "up": [0, 0, 1], "rotation": [[1, 0, 0], [0, 0, -1], [0, 1, 0]], "pelvis": pelvis}


def toml_text(joint_map: dict) -> str:
    """A joint map as TOML (the few shapes maps use)."""

    def value(v) -> str:
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = [f"{k} = {value(v)}" for k, v in joint_map.items() if k != "points"]
    lines.append("[points]")
    lines += [f"{k} = {value(v)}" for k, v in joint_map["points"].items()]
    return "\n".join(lines) + "\n"


# --- the runs ---------------------------------------------------------------------------------

WRISTS = ["LeftElbow_end", "RightElbow_end"]
STUDIO_WRISTS = ["lowerarm_l_end", "lowerarm_r_end"]
SCALE = "LeftHip=1.15,RightHip=1.15,LeftShoulder=0.9,RightShoulder=0.9"  # the same rig, other proportions


def deik_retarget(arguments: list[str]) -> float:
    """Run `deik retarget ARGUMENTS` in this process; its wall time (s). RuntimeError on failure."""
    from deik.cli.app import main

    began = time.perf_counter()
    status = main(["retarget", *arguments, "--quiet"])
    if status != 0:
        raise RuntimeError(f"deik retarget {' '.join(arguments)} exited {status}")
    return time.perf_counter() - began


def onto_robot(
    source_path: Path, robot_path: Path, map_path: Path, folder: Path, wrists: list[str], truth: Path | None = None
) -> dict:
    """Retarget `source_path` onto the URDF at `robot_path` through `map_path` and judge it
    against `truth` (default the source: the source without the errors a case added)."""
    out = folder / (source_path.stem + ".csv")
    report = folder / (source_path.stem + ".json")
    wall = deik_retarget(
        [str(source_path), "--map", str(map_path), "--to", str(robot_path), "--out", str(out), "--json", str(report)]
    )
    robot = read_robot(robot_path)
    joint_map = tomllib.loads(Path(map_path).read_text())
    pairing, names, values, dt = robot_pairing(robot, out, joint_map)
    source = read_bvh_file(truth or source_path)
    steps = {"robot": robot, "names": names, "values": values, "frame_time": dt}
    figures = judge(source, pairing, wrists, 1000.0, steps)  # a URDF is in metres
    return {**figures, "wall_s": wall, "deik": json.loads(report.read_text())["summary"]}


def onto_rig(source_path: Path, folder: Path, scale: str = SCALE) -> dict:
    """Retarget `source_path` onto its own rig with other proportions (--scale) and judge it
    against the floor deik states (the target keeps the source's world, whose floor only the
    capture knows), with the judge's own estimate of that floor beside it."""
    out, report = folder / (source_path.stem + "_scaled.bvh"), folder / (source_path.stem + "_scaled.json")
    wall = deik_retarget([str(source_path), "--scale", scale, "--out", str(out), "--json", str(report)])
    source = read_bvh_file(source_path)
    size = stature(source)
    deik = json.loads(report.read_text())
    floor = deik["floor"]["height"]
    mm = 1000.0 if size < 10 else 10.0  # the rig's unit: metres or centimetres
    figures = judge(source, rig_pairing(source, read_bvh_file(out), floor), WRISTS, mm)
    own = source_floor(source, bvh_transforms(source)[0], size)
    return {**figures, "floor_stated_mm_from_judge": (floor - own) * mm, "wall_s": wall, "deik": deik["summary"]}


def plan(clips: list[Path], quick: bool) -> list[dict]:
    """The runs: every clip onto human.urdf and onto its own rig scaled; each source case on a
    few clips onto human.urdf; each robot case on a few clips."""
    by_name = {c.stem.removeprefix("humanoid3d_"): c for c in clips}
    runs = [{"clip": name, "case": "as captured", "target": "human.urdf"} for name in by_name]
    runs += [{"clip": name, "case": "as captured", "target": "same rig, scaled"} for name in by_name]
    hard = {
        "backwards": "crawl", "sped_up": "kick", "long_legs": "walk", "noisy": "punch", "studio": "walk",
        "crossing": "walk",
    }  # fmt: skip
    hard_robots = {"reordered": "kick", "continuous": "dance_a", "slow": "jump", "z_up": "crawl"}
    runs += [{"clip": clip, "case": case, "target": "human.urdf"} for case, clip in hard.items()]
    runs += [{"clip": clip, "case": "120fps_noisy", "target": "human.urdf"} for clip in ("walk", "run", "kick")]
    runs += [{"clip": clip, "case": "30fps_noisy", "target": "human.urdf"} for clip in ("walk", "kick")]
    runs += [
        {"clip": clip, "case": "as captured", "target": f"human.urdf, {case}"} for case, clip in hard_robots.items()
    ]
    runs = [r for r in runs if r["clip"] in by_name]
    return [r for r in runs if r["clip"] == "walk"] if quick else runs


JUDGED_NOISY = {"120fps_noisy": "_120fps_noisy", "30fps_noisy": "_noisy"}  # run case: judging/cases.py's case


def retarget_case(spec: dict, clips: dict, folder: Path) -> dict:
    """Make the case of `spec` in `folder`, retarget it and judge it."""
    original = clips[spec["clip"]]
    source_path, map_path, robot_path, wrists = original, URDF_MAP, HUMAN_URDF, WRISTS
    if spec["case"] in JUDGED_NOISY:  # judging/cases.py's, judged against the clip without its noise
        name = spec["clip"] + JUDGED_NOISY[spec["case"]]
        case = next(c for c in cases(original.parent, [spec["clip"]]) if c.name == name)
        source_path, truth = folder / f"{case.name}.bvh", folder / f"{case.name}_truth.bvh"
        source_path.write_text(format_rig(case.rig))
        truth.write_text(format_rig(case.truth))
        return onto_robot(source_path, robot_path, map_path, folder, wrists, truth)
    if spec["case"] != "as captured":
        bvh = source_case(read_bvh_file(original), spec["case"])
        source_path = folder / f"{spec['clip']}_{spec['case']}.bvh"
        write_bvh_file(source_path, bvh)
        if spec["case"] == "studio":
            map_path, wrists = folder / "studio_map.toml", STUDIO_WRISTS
            map_path.write_text(toml_text(studio_map(tomllib.loads(URDF_MAP.read_text()))))
    if spec["target"] == "same rig, scaled":
        return onto_rig(source_path, folder)
    if ", " in spec["target"]:
        robot = spec["target"].split(", ")[1]
        robot_path = folder / f"human_{robot}.urdf"
        robot_path.write_text(robot_case(HUMAN_URDF.read_text(), robot))
        if robot == "z_up":
            map_path = folder / "z_up_map.toml"
            map_path.write_text(toml_text(z_up_map(tomllib.loads(URDF_MAP.read_text()))))
    return onto_robot(source_path, robot_path, map_path, folder, wrists)


SHOWN = (
    ("sliding_max_mm_per_frame", "sliding mm/frame"),
    ("penetration_max_mm", "under floor mm"),
    ("step_excess_max", "step / allowance"),
    ("wrap_count", "wraps"),
    ("wrist_distance_max_mm", "wrist mm"),
    ("speed_peak_ratio_max", "speed peak / source's"),
    ("keypoint_error_mean_mm", "key points mm"),
)


def table(rows: list[dict]) -> str:
    """The short Markdown table of the runs, with the bounds."""
    header = ["clip", "case", "target", "frames"] + [label for _, label in SHOWN] + ["resting points"]
    cells = []
    for row in rows:
        values = [row.get(key) for key, _ in SHOWN]
        shown = ["-" if v is None else f"{v:.3g}" if isinstance(v, float) else str(v) for v in values]
        cells.append([row["clip"], row["case"], row["target"], row.get("frames", ""), *shown])
        cells[-1].append(", ".join(row.get("resting_points", [])) or "-")
    return md_table(header, cells) + (
        f"\nBounds: sliding <= {SLIDING_BOUND} mm/frame over every point resting in the source, nothing more than "
        f"{PENETRATION_BOUND} mm under the floor, every DOF step within max(velocity limit x frame time, "
        f"{STEP_ALLOWANCE} x the source's largest joint turn per frame) (step / allowance <= 1), no wraps, "
        f"a hand within {WRIST_BOUND} statures of the target of its scaled source point.\n"
    )


def main(argv: list[str] | None = None) -> dict:
    """Run the plan, write retarget_quality.json and .md under --out, print the table."""
    p = parser(__doc__)
    p.add_argument("--clips", type=Path, help="folder of clips (default the shared ones)")
    p.add_argument("--only", help="run only the plan entries whose clip, case or target contains this text")
    p.add_argument("--robot", type=Path, help="instead of the plan, every clip as captured onto this URDF (with --map)")
    p.add_argument("--map", type=Path, help="the joint map from the clips' rig onto --robot")
    run = start("retarget_quality", p, argv)
    args = run.args
    if (args.robot is None) != (args.map is None):
        raise SystemExit("retarget_quality: give --robot FILE.urdf and --map MAP.toml together")
    for option, path in (("--robot", args.robot), ("--map", args.map)):
        if path is not None and not path.is_file():
            raise SystemExit(f"retarget_quality: {option} {path}: no such file")
    args.clips = args.clips or need("humanoid")
    need("robots", "human.urdf")
    clips = {c.stem.removeprefix("humanoid3d_"): c for c in sorted(args.clips.glob("*.bvh"))}
    specs = plan(list(clips.values()), args.quick)
    if args.robot:
        specs = [{"clip": name, "case": "as captured", "target": args.robot.name} for name in clips]
        specs = specs[:1] if args.quick else specs
    if args.only:
        specs = [s for s in specs if any(args.only in s[k] for k in ("clip", "case", "target"))]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for spec in specs:
            folder = Path(tmp) / f"{spec['clip']}_{len(rows)}"
            folder.mkdir()
            try:
                if args.robot:
                    row = {**spec, **onto_robot(clips[spec["clip"]], args.robot, args.map, folder, WRISTS)}
                else:
                    row = {**spec, **retarget_case(spec, clips, folder)}
            except Exception as error:  # a failed run is a row of the table, not the end of the benchmark
                row = {**spec, "failed": f"{type(error).__name__}: {error}"}
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k not in ("deik", "resting_points")}), flush=True)
    figures = {f"{r['clip']} {r['case']} {r['target']} {key}": r.get(key) for r in rows for key, _ in SHOWN}
    return run.finish({"runs": rows}, table(rows), figures=figures)


if __name__ == "__main__":
    main()
