"""Whole motion clips: contacts, target tracks, metrics and reports for fixing every frame at once;
deik.clean_clip (clean.py) is the way in, from one CleanOptions."""
