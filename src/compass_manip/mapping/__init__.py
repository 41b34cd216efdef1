"""Occupancy mapping from depth images: plain arrays in, no simulator."""
