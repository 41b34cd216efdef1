"""Exploration: how a method chooses where the wrist camera looks next (Task + map only)."""
