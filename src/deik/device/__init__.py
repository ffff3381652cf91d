"""The device maths, written once in plain Python and compiled for every target: named kernel
data (layout.py), forward kinematics, objective terms, DE trials, the LM polish, the per-individual driver."""
