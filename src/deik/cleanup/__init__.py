"""Whole motion clips: contacts, target tracks, metrics and reports for fixing every frame at once;
deik.clean_clip (api.py) is the way in, from one CleanOptions."""
