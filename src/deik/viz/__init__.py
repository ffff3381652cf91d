"""Pictures and text views: pose plots, clip reports, tables."""
