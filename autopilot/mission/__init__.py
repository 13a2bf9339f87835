"""Missions: items with MAVLink semantics (items.py) and .waypoints / .plan files (files.py)."""
