"""The mission: scenario files, the planner and its strategies, the energy-sharing loop, results."""
