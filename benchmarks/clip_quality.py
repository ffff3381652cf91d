"""Every shared humanoid clip fixed as an animator would use it: contacts, floor, balance, and a
known answer (issue 17 item 7). One table: JSON, markdown and PNG.

    python -m benchmarks.clip_quality [--quick] [--clips walk run ...] [--out benchmarks/results]

Each clip of the shared data's humanoid/ (--clips: those named; with --quick, the first 40 frames of
each) with its segment masses:

1. contacts, as `deik clip` fixes it with no flags (every point of the body that rests, soles
   included, the floor detected and kept): the largest slide of a contact point between two
   contact frames (mm/frame, target <= 0.5), the foot-skating
   ratio (target 0), the deepest point below the floor (mm, target <= 1), the largest of the
   four peak ratios against the capture (rotation-channel velocity and acceleration, joint and
   site velocity and acceleration, cleanup/dynamics.py; target <= 1.10), the frames meeting
   every goal and the seconds.
2. balance, the same with --balance: the frames whose zero-moment point it keeps over the
   support and those it skips (cleanup/balance.py), the mean ZMP distance outside the support
   (soles included) over the kept frames before and after, and the largest peak ratio
   (target <= 1.10).
3. a known answer: the legs' rotation channels (hips, knees, ankles; not the channels the
   capture holds at 0) get smooth noise, white noise low-passed by a Gaussian of standard
   deviation 0.05 s (some 0.15 s across) and scaled so each joint turns 4 degrees RMS (each
   of its k channels 4 / sqrt(k)); the corrupted clip is fixed with the clean clip's contact
   points held where the clean clip has them in every frame (ClipGoals.plants) and its floor.
   Measured: the joint-position RMS error against the clean clip before and after the fix
   (target: after <= half of before).

Records every number and the settings; in the table a target not met is marked "(missed)".
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from benchmarks import harness
from benchmarks.data import need
from deik.cleanup.body import on_body
from deik.cleanup.clip_goals import ClipGoals
from deik.cleanup.coherence import hinge_channels
from deik.cleanup.contacts import Contacts, site_positions
from deik.cleanup.dynamics import PEAK_RATIO, peak_ratios
from deik.cleanup.fix import fix_clip
from deik.cleanup.ground import resting_body
from deik.cleanup.summary import clip_report, per_frame_errors
from deik.io.bvh import read_bvh
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics

QUICK_FRAMES = 40
TARGETS = {"sliding_mm_per_frame": 0.5, "skating_ratio": 0.0, "penetration_mm": 1.0, "peak_ratio": PEAK_RATIO}
NOISE_DEGREES, NOISE_SECONDS, LEGS = 4.0, 0.05, ("Hip", "Knee", "Ankle")
KNOWN_ANSWER_RATIO = 0.5


def load(path: Path, frames: int):
    """The clip at `path` with its segment masses, its first `frames` (0: all)."""
    clip = read_bvh(path, segments=str(path).replace(".bvh", ".segments.json"))
    return dataclasses.replace(clip, frames=clip.frames[:frames]) if frames else clip


def animator_contacts(clip):
    """(body, contacts, floor height) as `deik clip` finds them with no flags: every point of the
    body that rests, the floor detected."""
    body, floor, contacts = resting_body(clip)
    return body, contacts, floor.height


def contacts_row(clip, seed: int) -> dict:
    """Item 1 of the module notes for one clip."""
    body, contacts, floor = animator_contacts(clip)
    began = time.perf_counter()
    fix = fix_clip(clip, ClipGoals(contacts, floor=floor), seed=seed, body=body)
    seconds = time.perf_counter() - began
    report = clip_report(*fix.on_body(), contacts)
    ratios = peak_ratios(clip, fix.clip)
    return {
        "contact_points": [str(site) for site in contacts.sites],
        "floor_m": floor,
        "sliding_mm_per_frame": report["sliding_max_mm_per_frame"]["after"],
        "sliding_before_mm_per_frame": report["sliding_max_mm_per_frame"]["before"],
        "skating_ratio": report["foot_skating_ratio_share"]["after"],
        "penetration_mm": report["penetration_max_mm"]["after"],
        "penetration_before_mm": report["penetration_max_mm"]["before"],
        "peak_ratios": ratios,
        "peak_ratio": max(ratios.values()),
        "joint_deviation_max_deg": report["joint_angle_deviation_max_deg"]["after"],
        "frames_met": int(fix.met.sum()),
        "seconds": seconds,
    }


def balance_row(clip, seed: int) -> dict:
    """Item 2 of the module notes for one clip."""
    body, contacts, floor = animator_contacts(clip)
    began = time.perf_counter()
    fix = fix_clip(clip, ClipGoals(contacts, balance=True, floor=floor), seed=seed, body=body)
    seconds = time.perf_counter() - began
    report = clip_report(*fix.on_body(), contacts)
    kept = fix.balance.balanced & fix.met
    zmp = per_frame_errors(*fix.on_body(), contacts)["zmp_outside_support_mm"]
    ratios = peak_ratios(clip, fix.clip)
    return {
        "balanced_frames": int(kept.sum()),
        "skipped_frames": int(fix.balance.skipped.sum()),
        "supported_frames": int(contacts.mask.any(axis=1).sum()),
        "zmp_outside_before_mm": float(np.nanmean(zmp["before"][kept])) if kept.any() else None,
        "zmp_outside_after_mm": float(np.nanmean(zmp["after"][kept])) if kept.any() else None,
        "peak_ratios": ratios,
        "peak_ratio": max(ratios.values()),
        "joint_deviation_mean_deg": report["joint_angle_deviation_mean_deg"]["after"],
        "frames_met": int(fix.met.sum()),
        "seconds": seconds,
    }


def corrupted(clip, seed: int):
    """The clip with smooth noise on its legs' free rotation channels (module notes, item 3), and
    the number of channels."""
    from scipy.ndimage import gaussian_filter1d

    sk = clip.skeleton
    joint = [sk.dof_names[d].split(".")[0] for d in range(sk.n_dofs)]
    legs = np.array([name.endswith(LEGS) for name in joint])  # RightHip, LeftKnee, ...: not Hips, the root
    channels = np.flatnonzero(legs & (sk.dof_kind == ROTATE) & ~hinge_channels(clip))
    per_joint = {name: sum(joint[d] == name for d in channels) for name in {joint[d] for d in channels}}
    noise = np.random.default_rng(seed).normal(size=(clip.n_frames, len(channels)))
    noise = gaussian_filter1d(noise, NOISE_SECONDS / clip.frame_time, axis=0, mode="reflect")
    scale = np.radians(NOISE_DEGREES) / np.sqrt([per_joint[joint[d]] for d in channels])
    noise *= scale / np.sqrt((noise**2).mean(axis=0))
    frames = clip.frames.copy()
    frames[:, channels] += noise
    return clip.with_frames(frames), len(channels)


def joint_rms_mm(clip, other) -> float:
    """RMS over frames and joints of the distance between the joints of two clips, mm."""
    J = clip.skeleton.n_joints
    a, b = (forward_kinematics(c.skeleton, c.frames).p_world_frame[:, :J] for c in (clip, other))
    return 1000.0 * float(np.sqrt(((a - b) ** 2).sum(axis=-1).mean()))


def known_answer_row(clip, seed: int) -> dict:
    """Item 3 of the module notes for one clip."""
    body, contacts, floor = animator_contacts(clip)
    noisy, channels = corrupted(clip, seed)
    held = Contacts(contacts.sites, np.ones_like(contacts.mask), False, None, None, floor, contacts.clearance)
    goals = ClipGoals(held, floor=floor, plants=site_positions(on_body(clip, body), contacts.sites))
    fix = fix_clip(noisy, goals, seed=seed, body=body)
    before, after = joint_rms_mm(clip, noisy), joint_rms_mm(clip, fix.clip)
    return {"channels": channels, "rms_before_mm": before, "rms_after_mm": after, "ratio": after / before}


def verdicts(row: dict) -> dict:
    """{target: met} for one clip's row."""
    c, b, k = row["contacts"], row["balance"], row["known_answer"]
    met = {
        "sliding": c["sliding_mm_per_frame"] <= TARGETS["sliding_mm_per_frame"],
        "skating": c["skating_ratio"] <= TARGETS["skating_ratio"],
        "penetration": c["penetration_mm"] <= TARGETS["penetration_mm"],
        "peaks": c["peak_ratio"] <= PEAK_RATIO,
        "balance_peaks": b["peak_ratio"] <= PEAK_RATIO,
        "known_answer": k["ratio"] <= KNOWN_ANSWER_RATIO,
    }
    return {key: bool(value) for key, value in met.items()}


def _cell(value: float, ok: bool, digits: str = ".3g") -> str:
    return f"{value:{digits}}" + ("" if ok else " (missed)")


def table(rows: list[dict]) -> str:
    """The markdown table of every clip, a target not met marked "(missed)"."""
    header = [
        "clip",
        "frames",
        "sliding max mm/frame (<= 0.5)",
        "skating ratio (0)",
        "penetration max mm (<= 1)",
        "peak ratio (<= 1.1)",
        "--balance: ZMP kept / skipped frames",
        "ZMP outside mm, kept frames",
        "--balance peak ratio (<= 1.1)",
        "known answer: joint RMS mm (after <= half)",
    ]
    out = []
    for row in rows:
        c, b, k, ok = row["contacts"], row["balance"], row["known_answer"], row["verdicts"]
        zmp = (
            "-"
            if b["zmp_outside_before_mm"] is None
            else f"{b['zmp_outside_before_mm']:.3g} -> {b['zmp_outside_after_mm']:.3g}"
        )
        out.append(
            [
                row["clip"],
                row["frames"],
                _cell(c["sliding_mm_per_frame"], ok["sliding"]),
                _cell(c["skating_ratio"], ok["skating"]),
                _cell(c["penetration_mm"], ok["penetration"]),
                _cell(c["peak_ratio"], ok["peaks"], ".3f"),
                f"{b['balanced_frames']} / {b['skipped_frames']}",
                zmp,
                _cell(b["peak_ratio"], ok["balance_peaks"], ".3f"),
                f"{k['rms_before_mm']:.3g} -> " + _cell(k["rms_after_mm"], ok["known_answer"]),
            ]
        )
    return harness.md_table(header, out)


def figure(rows: list[dict], title: str):
    """Four panels, one bar per clip: sliding, penetration, peak ratios, known-answer ratio, with
    their target lines."""
    names = [row["clip"].replace("humanoid3d_", "") for row in rows]
    x = np.arange(len(rows))
    fig, axes = harness.figure(2, 2, width=6, height=3.5)
    panels = [
        (axes[0, 0], [r["contacts"]["sliding_mm_per_frame"] for r in rows], 0.5, "sliding max (mm/frame)"),
        (axes[0, 1], [r["contacts"]["penetration_mm"] for r in rows], 1.0, "penetration max (mm)"),
        (
            axes[1, 1],
            [r["known_answer"]["ratio"] for r in rows],
            KNOWN_ANSWER_RATIO,
            "known answer: RMS after / before",
        ),
    ]
    for ax, values, target, label in panels:
        ax.bar(x, values, color="tab:blue")
        ax.axhline(target, color="tab:red", lw=1, ls="--", label="target")
        ax.set_ylabel(label)
    ax = axes[1, 0]
    ax.bar(x - 0.2, [r["contacts"]["peak_ratio"] for r in rows], 0.4, label="contacts and floor")
    ax.bar(x + 0.2, [r["balance"]["peak_ratio"] for r in rows], 0.4, label="with --balance")
    ax.axhline(PEAK_RATIO, color="tab:red", lw=1, ls="--", label="target")
    ax.set_ylim(0.8, max(1.2, ax.get_ylim()[1]))
    ax.set_ylabel("largest peak / capture's")
    ax.legend(fontsize="small")
    for ax in axes.ravel():
        ax.set_xticks(x, names, rotation=30, fontsize="small")
        ax.grid(alpha=0.3, axis="y")
    fig.suptitle(title)
    return fig


def main(argv=None) -> dict:
    """Measure every clip; write the JSON, Markdown and PNG."""
    p = harness.parser(__doc__)
    p.add_argument("--clips", nargs="+", metavar="NAME", help="clips by name (walk, run, ...; default all)")
    run = harness.start("clip_quality", p, argv)
    args = run.args
    frames = QUICK_FRAMES if args.quick else 0
    folder = need("humanoid")
    paths = [folder / f"humanoid3d_{name}.bvh" for name in args.clips] if args.clips else sorted(folder.glob("*.bvh"))
    missing = [str(path) for path in paths if not path.is_file()]
    if missing:
        raise SystemExit(f"--clips: no clip {', '.join(missing)}")
    rows = []
    for k, path in enumerate(paths):
        clip = load(path, frames)
        row = {"clip": path.stem, "frames": clip.n_frames, "frame_time_s": clip.frame_time}
        row["contacts"] = contacts_row(clip, args.seed)
        row["balance"] = balance_row(clip, args.seed)
        row["known_answer"] = known_answer_row(clip, args.seed + k)
        row["verdicts"] = verdicts(row)
        rows.append(row)
        print(f"{path.stem}: {row['verdicts']}", flush=True)
    met = all(all(row["verdicts"].values()) for row in rows)
    run.target("clips meeting every target", len(rows), sum(all(r["verdicts"].values()) for r in rows), "clips")
    result = {
        "frames": frames,
        "goals": {**TARGETS, "known_answer_ratio": KNOWN_ANSWER_RATIO},
        "noise": {"degrees_rms": NOISE_DEGREES, "gaussian_sd_s": NOISE_SECONDS, "joints": list(LEGS)},
        "clips": rows,
        "all_met": met,
    }
    figures = {
        f"{r['clip']} {part} {key}": r[part][key]
        for r in rows
        for part, key in (
            ("contacts", "sliding_mm_per_frame"),
            ("contacts", "penetration_mm"),
            ("contacts", "peak_ratio"),
            ("balance", "peak_ratio"),
            ("known_answer", "ratio"),
        )
    }
    return run.finish(result, table(rows), figure(rows, "deik clip on the shared humanoid clips"), figures)


if __name__ == "__main__":
    main()
