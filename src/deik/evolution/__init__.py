"""Differential evolution: the parallel engine (engine.py) and the paper's serial reference (serial.py)."""
