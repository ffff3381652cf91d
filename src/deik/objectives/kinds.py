"""Term kinds and the columns of the term table: the integer codes the kernels branch on.

Every other module names them from here (the registry of goal kinds in objectives/registry.py
adds each kind's name, unit, file schema and CLI label). Columns index the arrays of a
TermTable (objectives/table.py): TERM_* of term_int (T, 3 + MAX_TERM_FRAMES), WEIGHT..
PRIORITY_TOLERANCE of term_float (T, 5), GAIN of params (B, T, N_PARAMS), and PAIR_* of
pair_int (K, 3), the bone pairs that self-collision terms test.
"""

# term kinds
POSITION, ORIENTATION, AIM, COM, COM_GROUND, SUPPORT_POLYGON = 0, 1, 2, 3, 4, 5
COMFORT_SUM, COMFORT_MAX, LIMITS, OBSTACLE, SELF_COLLISION = 6, 7, 8, 9, 10
FLOOR = 11

# term_int columns: kind, priority level, frame count, then up to MAX_TERM_FRAMES frame indices
TERM_KIND, TERM_LEVEL, TERM_FRAME_COUNT, TERM_FRAMES = 0, 1, 2, 3
MAX_TERM_FRAMES = 8
# term_float columns: weight in [-1, 1], mu, distance scale, tolerance (-1: none), f(tolerance) (-1: plain w f)
WEIGHT, MU, SCALE, TOLERANCE, PRIORITY_TOLERANCE = 0, 1, 2, 3, 4
# params (B, T, N_PARAMS): a term's targets per problem; the last column is its gain (0 = off)
N_PARAMS = 12
GAIN = N_PARAMS - 1
MAX_LEVELS = 4
# pair_int columns: the self-collision term the pair belongs to, then the two bones (each named
# by its end frame, deik.model.capsules); pair_radius (K,) holds their capsule radii's sum
PAIR_TERM, PAIR_A, PAIR_B = 0, 1, 2
