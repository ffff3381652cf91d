"""Peer IK and DE libraries, run in their own venv (.venv-peers) by benchmarks.robots and benchmarks.de_peers."""
