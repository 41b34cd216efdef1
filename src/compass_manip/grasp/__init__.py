"""Grasping: the target model, GraspNet-scored antipodal candidates and the paper's
constrained selection (Eq. 6). Method side: imports task, types, errors, geometry, robot,
mapping and motion only (tests/test_grasp_layering.py)."""
