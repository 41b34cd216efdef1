"""Occupancy mapping from depth images: plain arrays in, no simulator.

occupancy    OccupancyMap, MapConfig, VoxelState: log-odds grid, integrate(), queries
raycast      back-projection and the 3-D DDA set-up shared by the kernels
integration  scan integration kernels (OctoMap's update rule, ray grouping)
selffilter   SphereBodyFilter: drop depth points on the robot's own body
observe      integrate_observation(): the one sense -> map step (self-filter + integrate)
frontiers    frontier voxels and clusters
infogain     information gain of camera views (single and batch); gain_kernels: its kernels
distance     distance field of unsafe (occupied or unknown) space, carve-outs, lookups
octomap_io   OctoMap OcTree conversion and .bt files
"""
