"""One trial: wires the simulator, the exploration method and the detector together, runs
the state machine on a simulated clock and records the metrics."""
