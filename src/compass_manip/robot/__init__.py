"""The Panda as a model: assets, limits, camera mount, kinematics. No simulator state."""
