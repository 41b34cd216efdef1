"""Perception: finding the target described by a `TargetQuery` in wrist-camera images
(RGB + depth + camera pose only, never simulator labels), and the asynchronous detection
buffer that keeps detection off the motion's critical path."""
