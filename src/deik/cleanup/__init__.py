"""Whole motion clips: contacts, target tracks, metrics and reports for fixing every frame at once."""
