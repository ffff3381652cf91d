"""Anthropometric tables shared by the built-in humanoid and the segment-mass estimate of BVH files.

de Leva (1996), "Adjustments to Zatsiorsky-Seluyanov's segment inertia parameters", J. Biomech.
29(9): mean male segment lengths (as fractions of his mean stature) and Table 4's mass
percentages and centre-of-mass positions.
"""

# de Leva's mean male lengths (mm) over his mean stature of 1741 mm.
LOWER_TRUNK = 145.7 / 1741.0  # mid-hip to omphalion
MIDDLE_TRUNK = 215.5 / 1741.0  # omphalion to xiphion
UPPER_TRUNK = 170.7 / 1741.0  # xiphion to suprasternale
HEAD = 203.3 / 1741.0  # mid-gonion to vertex
HAND = 86.2 / 1741.0  # wrist joint centre to third knuckle
# de Leva (1996) Table 4, males: percent of body mass, and the centre of mass as a fraction of
# the segment length from its first endpoint (head: vertex; trunk parts: their upper end;
# limbs: proximal joint; foot: heel).
DE_LEVA = {
    "head": (6.94, 0.5976),
    "upper_trunk": (15.96, 0.2999),
    "middle_trunk": (16.33, 0.4502),
    "lower_trunk": (11.17, 0.6115),
    "upper_arm": (2.71, 0.5772),
    "forearm": (1.62, 0.4574),
    "hand": (0.61, 0.7900),
    "thigh": (14.16, 0.4095),
    "shank": (4.33, 0.4395),
    "foot": (1.37, 0.4415),
}
PAIRED = ("upper_arm", "forearm", "hand", "thigh", "shank", "foot")
# The published percentages sum to 100.00; segment masses are divided by this total so they add
# up to the requested mass exactly, and a mistyped entry fails here instead of skewing the body.
DE_LEVA_TOTAL = sum(p * (2 if name in PAIRED else 1) for name, (p, _) in DE_LEVA.items())
if abs(DE_LEVA_TOTAL - 100.0) > 0.05:
    raise AssertionError(f"de Leva mass table sums to {DE_LEVA_TOTAL}%, not 100%")
