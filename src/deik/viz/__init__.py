"""Pictures and text views: pose plots, clip reports, tables, and the 3-D view in the browser (view.py)."""
