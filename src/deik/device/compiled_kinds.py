"""Which term kinds the device maths is compiled for: one switch per group of kinds that shares
code, all on here.

Run as plain Python and on the GPU every switch is on. The CPU back-end compiles a copy of the
device maths for the set of kinds a problem uses, with the other switches off
(deik.backends.targets): the code branches as `if POSITION_ON and kind == POSITION`, and Numba
prunes a branch on a constant False before typing it, so a reach-only problem never compiles the
orientation, centre of mass, support polygon or self-collision code. A switch changes what is
compiled, never a result: a problem only ever reaches the branches of its own kinds.
"""

from deik.objectives import kinds

POSITION_ON = True
ORIENTATION_ON = True
AIM_ON = True
COM_ON = True  # a centre of mass, or its ground projection, at a point
SUPPORT_POLYGON_ON = True
COMFORT_ON = True
LIMITS_ON = True
OBSTACLE_ON = True
SELF_COLLISION_ON = True
FLOOR_ON = True
CENTRE_OF_MASS_ON = True  # on when COM_ON or SUPPORT_POLYGON_ON is: the COM is summed

# each switch and the term kinds it compiles (CENTRE_OF_MASS_ON follows from the others)
SWITCHES = {
    "POSITION_ON": (kinds.POSITION,),
    "ORIENTATION_ON": (kinds.ORIENTATION,),
    "AIM_ON": (kinds.AIM,),
    "COM_ON": (kinds.COM, kinds.COM_GROUND),
    "SUPPORT_POLYGON_ON": (kinds.SUPPORT_POLYGON,),
    "COMFORT_ON": (kinds.COMFORT_SUM, kinds.COMFORT_MAX),
    "LIMITS_ON": (kinds.LIMITS,),
    "OBSTACLE_ON": (kinds.OBSTACLE,),
    "SELF_COLLISION_ON": (kinds.SELF_COLLISION,),
    "FLOOR_ON": (kinds.FLOOR,),
}
CENTRE_OF_MASS_SWITCHES = frozenset({"COM_ON", "SUPPORT_POLYGON_ON"})  # the switches that sum the COM
