"""The body model: DOF and joint specs, the frozen Skeleton, forward kinematics, rotations, builders."""
