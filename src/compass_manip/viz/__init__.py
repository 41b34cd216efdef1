"""Pictures and plots for people: PNG images of frames and scenes, map slices, curves."""
