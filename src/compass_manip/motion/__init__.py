"""Validity checking and motion planning on the map: plain arrays in, no simulator."""
